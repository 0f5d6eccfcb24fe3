"""Feasibility of the start of a band against the costmap footprint (docs/reference.md §4.5 step 9).

Reproduces base_local_planner's CostmapModel::footprintCost for the "-1" answer only: the
footprint outline is rasterised edge by edge with the costmap LineIterator, and the first
lethal or unknown cell met in that order decides the result (lethal -> -1, unknown -> -2).
A vertex or centre off the map gives -3. Only -1 makes a band infeasible.
"""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.costmap.cost_values import (INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE,
                                                      NO_INFORMATION)
from simplebot_navigation.geometry import normalize_theta


def line_cells(x0, y0, x1, y1):
    """Vectorised costmap LineIterator (Bresenham) for many lines at once.

    Returns (line index, mx, my) of every visited cell, endpoints included, in visiting order.
    The minor coordinate after k steps advanced floor((den // 2 + k * numadd) / den) times.
    """
    dx, dy = np.abs(x1 - x0), np.abs(y1 - y0)
    sx, sy = np.where(x1 >= x0, 1, -1), np.where(y1 >= y0, 1, -1)
    x_major = dx >= dy
    den = np.where(x_major, dx, dy)
    numadd = np.where(x_major, dy, dx)
    counts = den + 1
    line = np.repeat(np.arange(len(x0)), counts)
    k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    den_l = np.maximum(den[line], 1)
    minor = (den[line] // 2 + k * numadd[line]) // den_l
    xm = x_major[line]
    mx = x0[line] + sx[line] * np.where(xm, k, minor)
    my = y0[line] + sy[line] * np.where(xm, minor, k)
    return line, mx, my


def footprint_costs(costmap, footprint: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """footprintCost sign per pose: -1 lethal, -2 unknown, -3 off map, 0 otherwise."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    out = np.zeros(len(poses))
    grid = costmap.costmap
    cx, cy, centre_ok = costmap.world_to_map_array(poses[:, 0], poses[:, 1])
    out[~centre_ok] = -3.0
    if len(fp) < 3:
        cost = np.where(centre_ok, grid[np.where(centre_ok, cy, 0), np.where(centre_ok, cx, 0)], 0)
        out[centre_ok & (cost == NO_INFORMATION)] = -2.0
        out[centre_ok & ((cost == LETHAL_OBSTACLE) | (cost == INSCRIBED_INFLATED_OBSTACLE))] = -1.0
        return out
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    wx = poses[:, 0:1] + c * fp[None, :, 0] - s * fp[None, :, 1]
    wy = poses[:, 1:2] + s * fp[None, :, 0] + c * fp[None, :, 1]
    vx, vy, v_ok = costmap.world_to_map_array(wx, wy)
    on_map = centre_ok & v_ok.all(axis=1)
    out[centre_ok & ~on_map] = -3.0
    idx = np.nonzero(on_map)[0]
    if not len(idx):
        return out
    nv = len(fp)
    x0, y0 = vx[idx].ravel(), vy[idx].ravel()
    x1, y1 = np.roll(vx[idx], -1, axis=1).ravel(), np.roll(vy[idx], -1, axis=1).ravel()
    # costmap_2d closes the polygon with an explicit last edge; the order of edges matters only
    # for which of lethal/unknown is met first, and line i precedes line i+1 as in the loop.
    line, mx, my = line_cells(x0, y0, x1, y1)
    cost = grid[my, mx]
    hit = (cost == LETHAL_OBSTACLE) | (cost == NO_INFORMATION)
    if not hit.any():
        return out
    pose_of_cell = line[hit] // nv
    first = np.unique(pose_of_cell, return_index=True)
    first_cost = cost[hit][first[1]]
    out[idx[first[0]]] = np.where(first_cost == LETHAL_OBSTACLE, -1.0, -2.0)
    return out


def is_trajectory_feasible(costmap, footprint, inscribed_radius: float, poses: np.ndarray,
                           no_poses: int, lookahead_distance: float, min_angular_resolution: float) -> bool:
    """Check the first ``no_poses`` band poses (fewer if lookahead_distance > 0 is reached first),
    inserting intermediate poses where consecutive ones are farther apart than the inscribed radius
    or turn more than min_angular_resolution."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    look = min(no_poses, len(poses) - 1)
    if lookahead_distance > 0:
        travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
        beyond = np.nonzero(travelled > lookahead_distance)[0]
        if len(beyond):
            look = min(look, int(beyond[0]))
    look = max(look, 0)
    check = [poses[: look + 1]]
    for i in range(look):
        d_rot = float(normalize_theta(poses[i + 1, 2] - poses[i, 2]))
        d_pos = poses[i + 1, :2] - poses[i, :2]
        dist = math.hypot(*d_pos)
        if abs(d_rot) > min_angular_resolution or dist > inscribed_radius:
            extra = int(max(math.ceil(abs(d_rot) / min_angular_resolution),
                            math.ceil(dist / inscribed_radius) if inscribed_radius > 0 else 1)) - 1
            if extra > 0:
                f = np.arange(1, extra + 1)[:, None] / (extra + 1.0)
                mid = np.empty((extra, 3))
                mid[:, :2] = poses[i, :2] + f * d_pos
                mid[:, 2] = normalize_theta(poses[i, 2] + f[:, 0] * d_rot)
                check.append(mid)
    return not bool(np.any(footprint_costs(costmap, footprint, np.vstack(check)) == -1.0))


def footprint_inscribed_radius(footprint: np.ndarray) -> float:
    """costmap_2d calculateMinAndMaxDistances: smallest distance from the centre to an edge."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    if len(fp) < 3:
        return float(np.min(np.hypot(fp[:, 0], fp[:, 1]))) if len(fp) else 0.0
    a, b = fp, np.roll(fp, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", -a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0, 1)
    closest = a + t[:, None] * ab
    return float(np.min(np.hypot(closest[:, 0], closest[:, 1])))
