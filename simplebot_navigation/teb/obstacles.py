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
    return pts[behind_robot_filter(pts, robot_pose, behind_robot_dist)]


def behind_robot_filter(points: np.ndarray, robot_pose, behind_robot_dist: float) -> np.ndarray:
    """Mask of the points TEB keeps: not (behind the robot and farther than behind_robot_dist)."""
    x, y, th = robot_pose
    rel = points - (x, y)
    behind = rel @ np.array([math.cos(th), math.sin(th)]) < 0
    far = np.einsum("ij,ij->i", rel, rel) > behind_robot_dist ** 2
    return ~(behind & far)


#: Force-included obstacles of one pose are kept per direction sector, the closest in each: the
#: cells of one wall push the same way, and a pose in a door sees dozens of them within reach.
FORCE_INCLUSION_SECTORS = 8
#: The closest obstacles left and right of a pose bound a gap when nothing else lies nearer to
#: their midpoint than this fraction of their half distance (a wall ahead has cells there).
GAP_FREE_FRACTION = 0.8


def associate_obstacles(model, poses: np.ndarray, obstacles: np.ndarray, min_obstacle_dist: float,
                        force_inclusion_factor: float, cutoff_factor: float):
    """Pairs (pose index, obstacle index) for the interior poses 1..n-1 and, per pair, the
    clearance of the gap the pose is passing (inf when it is not passing one).

    Kept: the obstacles closer than min_obstacle_dist*force_inclusion_factor (the closest one per
    direction sector), plus the closest obstacle on the left and on the right of the heading within
    min_obstacle_dist*cutoff_factor. The gap clearance is the footprint distance a pose would keep
    from both sides on the centre line between the closest obstacles left and right of it: in a
    door narrower than the distances ask for, no pose can keep min_obstacle_dist, and the
    optimiser then asks for the centre line instead of pushing the poses out of the door (which
    stalls the band, and the robot, in front of it)."""
    n_int = len(poses) - 2
    empty = np.zeros(0, dtype=np.int64)
    if n_int <= 0 or len(obstacles) == 0:
        return empty, empty, np.zeros(0)
    inner = poses[1:-1]
    cutoff = min_obstacle_dist * cutoff_factor
    # Cheap centre-distance prefilter: a model point is never farther than its bounding radius.
    rel = obstacles[None, :, :] - inner[:, None, :2]
    centre_d2 = np.einsum("nmj,nmj->nm", rel, rel)
    reach = cutoff + model_bounding_radius(model)
    keep = np.nonzero((centre_d2 <= reach * reach).any(axis=0))[0]
    if len(keep) == 0:
        return empty, empty, np.zeros(0)
    rel = rel[:, keep]
    dist = model.distances(inner, obstacles[keep])                            # n_int, K
    force = dist < min_obstacle_dist * force_inclusion_factor
    candidate = ~force & (dist <= cutoff)
    cross = np.cos(inner[:, 2])[:, None] * rel[..., 1] - np.sin(inner[:, 2])[:, None] * rel[..., 0]
    rows = np.arange(n_int)
    pose_idx, obst_idx = [], []
    picks = [np.where(candidate & side, dist, np.inf) for side in (cross > 0, cross <= 0)]
    sector = np.floor((np.arctan2(rel[..., 1], rel[..., 0]) + math.pi)
                      * (FORCE_INCLUSION_SECTORS / (2 * math.pi))).astype(np.int64)
    picks += [np.where(force & (sector == k), dist, np.inf) for k in range(FORCE_INCLUSION_SECTORS)]
    for d_pick in picks:
        j = np.argmin(d_pick, axis=1)
        ok = np.isfinite(d_pick[rows, j])
        pose_idx.append(rows[ok])
        obst_idx.append(j[ok])
    gap = _gap_clearance(model, inner, obstacles[keep], dist, cross)
    pose_idx = np.concatenate(pose_idx)
    return pose_idx + 1, keep[np.concatenate(obst_idx)], gap[pose_idx]


def _gap_clearance(model, inner, points, dist, cross) -> np.ndarray:
    """Per pose: the model's distance to the closest obstacles left and right of the heading when
    placed on their midpoint with the pose's heading, if free space lies between them and they are
    farther apart than the model is wide; else inf."""
    rows = np.arange(len(inner))
    left = np.argmin(np.where(cross > 0, dist, np.inf), axis=1)
    right = np.argmin(np.where(cross <= 0, dist, np.inf), axis=1)
    both = np.isfinite(dist[rows, left]) & (cross[rows, left] > 0) & (cross[rows, right] <= 0)
    a, b = points[left], points[right]
    mid = 0.5 * (a + b)
    half = 0.5 * np.hypot(*(b - a).T)
    to_mid = np.sqrt(((points[None, :, :] - mid[:, None, :]) ** 2).sum(axis=2)).min(axis=1)
    centred = np.column_stack([mid, inner[:, 2]])
    clearance = np.minimum(model.pair_distances(centred, a), model.pair_distances(centred, b))
    passable = (half > model.inscribed_radius) & (clearance > 0)
    return np.where(both & (to_mid >= GAP_FREE_FRACTION * half) & passable, clearance, np.inf)


def model_bounding_radius(model) -> float:
    """Largest distance from the robot centre to any point of the footprint model."""
    r = 0.0
    if len(model.circles):
        r = max(r, float(np.max(np.hypot(model.circles[:, 0], model.circles[:, 1]) + model.circles[:, 2])))
    if len(model.segments):
        r = max(r, float(np.max(np.hypot(model.segments[:, [0, 2]], model.segments[:, [1, 3]]))))
    return r
