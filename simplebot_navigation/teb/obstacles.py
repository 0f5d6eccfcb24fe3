"""Point obstacles from the local costmap and their association with band poses (REFERENCE §4.1, §4.4)."""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE


def costmap_point_obstacles(costmap, robot_pose, behind_robot_dist: float) -> np.ndarray:
    """Centres (M,2) of lethal cells, as updateObstacleContainerWithCostmap takes them: the last
    row and column are not scanned, and cells behind the robot farther than behind_robot_dist
    are skipped. Inflated (253) cells are not obstacles for the optimiser."""
    grid = costmap.costmap[:-1, :-1]
    my, mx = np.nonzero(grid == LETHAL_OBSTACLE)
    res = costmap.resolution
    pts = np.stack([costmap.origin_x + (mx + 0.5) * res, costmap.origin_y + (my + 0.5) * res], axis=1)
    x, y, th = robot_pose
    rel = pts - (x, y)
    behind = rel @ np.array([math.cos(th), math.sin(th)]) < 0
    far = np.einsum("ij,ij->i", rel, rel) > behind_robot_dist ** 2
    return pts[~(behind & far)]


def associate_obstacles(model, poses: np.ndarray, obstacles: np.ndarray, min_obstacle_dist: float,
                        force_inclusion_factor: float, cutoff_factor: float):
    """Pairs (pose index, obstacle index) for the interior poses 1..n-1: every obstacle closer
    than min_obstacle_dist*force_inclusion_factor, plus the closest obstacle on the left and on
    the right of the heading within min_obstacle_dist*cutoff_factor."""
    n_int = len(poses) - 2
    if n_int <= 0 or len(obstacles) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    inner = poses[1:-1]
    cutoff = min_obstacle_dist * cutoff_factor
    # Cheap centre-distance prefilter: a model point is never farther than its bounding radius.
    rel = obstacles[None, :, :] - inner[:, None, :2]
    centre_d2 = np.einsum("nmj,nmj->nm", rel, rel)
    reach = cutoff + model_bounding_radius(model)
    keep = np.nonzero((centre_d2 <= reach * reach).any(axis=0))[0]
    if len(keep) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    rel = rel[:, keep]
    dist = model.distances(inner, obstacles[keep])                            # n_int, K
    force = dist < min_obstacle_dist * force_inclusion_factor
    candidate = ~force & (dist <= cutoff)
    cross = np.cos(inner[:, 2])[:, None] * rel[..., 1] - np.sin(inner[:, 2])[:, None] * rel[..., 0]
    pose_idx, obst_idx = [], []
    fi, fj = np.nonzero(force)
    pose_idx.append(fi)
    obst_idx.append(fj)
    rows = np.arange(n_int)
    for side in (cross > 0, cross <= 0):
        d_side = np.where(candidate & side, dist, np.inf)
        j = np.argmin(d_side, axis=1)
        ok = np.isfinite(d_side[rows, j])
        pose_idx.append(rows[ok])
        obst_idx.append(j[ok])
    return np.concatenate(pose_idx) + 1, keep[np.concatenate(obst_idx)]


def model_bounding_radius(model) -> float:
    """Largest distance from the robot centre to any point of the footprint model."""
    r = 0.0
    if len(model.circles):
        r = max(r, float(np.max(np.hypot(model.circles[:, 0], model.circles[:, 1]) + model.circles[:, 2])))
    if len(model.segments):
        r = max(r, float(np.max(np.hypot(model.segments[:, [0, 2]], model.segments[:, [1, 3]]))))
    return r
