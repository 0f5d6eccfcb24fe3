"""Compiled footprint distances and obstacle association of the TEB optimiser.

A footprint model is the tuple (circles (C, 3) cx cy r, segments (S, 4) ax ay bx by, vertices
(V, 2), closed polygon flag), in the robot frame (FootprintModel.kernel_model builds it). Every
kernel is compiled with ``cache=True`` and releases the GIL; see edge_kernels for why numba.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from simplebot_navigation.geometry_kernels import inside_polygon

_TWO_PI = 2.0 * math.pi


# -- footprint models ------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def footprint_distance(x, y, th, px, py, model):
    """Distance from the model placed at pose (x, y, th) to the point (px, py), and its gradient
    with respect to the pose."""
    return footprint_distance_trig(x, y, math.cos(th), math.sin(th), px, py, model)


@njit(cache=True, nogil=True)
def footprint_distance_trig(x, y, c, s, px, py, model):
    """footprint_distance with the heading's cosine and sine (shared by all points of a pose). For
    segments the point goes to the robot frame, q = R(-th) (p - pose), and the pose gradient
    follows from dd/dpose_xy = -R(th) dd/dq and dd/dth = dd/dq . (q_y, -q_x)."""
    circles, segments, vertices, closed = model
    best, gx, gy, gth = np.inf, 0.0, 0.0, 0.0
    for k in range(circles.shape[0]):
        # circles in the world frame: the common case needs no rotation of the point
        cx, cy = circles[k, 0], circles[k, 1]
        ex, ey = px - (x + c * cx - s * cy), py - (y + s * cx + c * cy)
        norm = math.hypot(ex, ey)
        d = norm - circles[k, 2]
        if d < best:
            best = d
            inv = 1.0 / norm if norm > 1e-12 else 0.0
            gx, gy, gth = -ex * inv, -ey * inv, (ex * (s * cx + c * cy) - ey * (c * cx - s * cy)) * inv
    if segments.shape[0]:
        dx, dy = px - x, py - y
        qx, qy = c * dx + s * dy, -s * dx + c * dy
        seg_d, gqx, gqy = np.inf, 0.0, 0.0
        for k in range(segments.shape[0]):
            ax, ay = segments[k, 0], segments[k, 1]
            abx, aby = segments[k, 2] - ax, segments[k, 3] - ay
            aqx, aqy = qx - ax, qy - ay
            len2 = abx * abx + aby * aby
            t = (aqx * abx + aqy * aby) / (len2 if len2 > 0 else 1.0)
            t = min(max(t, 0.0), 1.0)
            ex, ey = aqx - t * abx, aqy - t * aby
            norm = math.sqrt(ex * ex + ey * ey)
            if norm < seg_d:
                seg_d = norm
                gqx, gqy = (ex / norm, ey / norm) if norm > 1e-12 else (0.0, 0.0)
        if closed and inside_polygon(qx, qy, vertices):
            seg_d, gqx, gqy = -seg_d, -gqx, -gqy
        if seg_d < best:
            best, gx, gy, gth = seg_d, -(c * gqx - s * gqy), -(s * gqx + c * gqy), gqx * qy - gqy * qx
    return best, gx, gy, gth


# -- obstacle association --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def associate_obstacles(poses, obstacles, model, min_obstacle_dist, force_inclusion_factor, cutoff_factor,
                        bounding_radius, inscribed_radius, sectors, gap_free_fraction):
    """Compiled obstacles.associate_obstacles: (pose indices, obstacle indices, gap clearances), pairs
    ordered by selection (all left picks, all right picks, then force inclusions sector by sector)."""
    n_int = poses.shape[0] - 2
    m = obstacles.shape[0]
    cutoff = min_obstacle_dist * cutoff_factor
    force_dist = min_obstacle_dist * force_inclusion_factor
    reach2 = (cutoff + bounding_radius) ** 2
    keep = np.empty(m, np.int64)
    n_keep = 0
    for j in range(m):
        for i in range(1, n_int + 1):
            ex, ey = obstacles[j, 0] - poses[i, 0], obstacles[j, 1] - poses[i, 1]
            if ex * ex + ey * ey <= reach2:
                keep[n_keep] = j
                n_keep += 1
                break
    picks = 2 + sectors
    pick = np.full((picks, max(n_int, 0)), -1, np.int64)
    pick_d = np.full((picks, max(n_int, 0)), np.inf)
    gap = np.full(max(n_int, 0), np.inf)
    for row in range(n_int):
        x, y, th = poses[row + 1, 0], poses[row + 1, 1], poses[row + 1, 2]
        c, s = math.cos(th), math.sin(th)
        left, right, left_d, right_d = -1, -1, np.inf, np.inf
        for kk in range(n_keep):
            j = keep[kk]
            ox, oy = obstacles[j, 0], obstacles[j, 1]
            rx, ry = ox - x, oy - y
            side = 0 if c * ry - s * rx > 0 else 1
            # No model point is farther from the pose than the bounding radius: skip the footprint
            # distance of a point that can beat neither the closest on its side, nor the pick of
            # its side, nor that of its sector.
            lower = math.sqrt(rx * rx + ry * ry) - bounding_radius - 1e-9
            sector = -1
            if lower < force_dist:
                sector = 2 + int(math.floor((math.atan2(ry, rx) + math.pi) * (sectors / _TWO_PI))) % sectors
            if (lower >= (left_d if side == 0 else right_d) and (lower > cutoff or lower >= pick_d[side, row])
                    and (sector < 0 or lower >= pick_d[sector, row])):
                continue
            d = footprint_distance_trig(x, y, c, s, ox, oy, model)[0]
            if side == 0 and d < left_d:
                left, left_d = j, d
            elif side == 1 and d < right_d:
                right, right_d = j, d
            if d < force_dist:
                slot = sector
            elif d <= cutoff:
                slot = side
            else:
                continue
            if d < pick_d[slot, row]:
                pick[slot, row], pick_d[slot, row] = j, d
        if left >= 0 and right >= 0:
            gap[row] = _gap_clearance(c, s, obstacles, keep[:n_keep], left, right, model,
                                      inscribed_radius, gap_free_fraction)
    count = 0
    for slot in range(picks):
        for row in range(n_int):
            count += pick[slot, row] >= 0
    pose_idx, obst_idx, gaps = np.empty(count, np.int64), np.empty(count, np.int64), np.empty(count)
    k = 0
    for slot in range(picks):
        for row in range(n_int):
            if pick[slot, row] >= 0:
                pose_idx[k], obst_idx[k], gaps[k] = row + 1, pick[slot, row], gap[row]
                k += 1
    return pose_idx, obst_idx, gaps


@njit(cache=True, nogil=True)
def _gap_clearance(c, s, obstacles, keep, left, right, model, inscribed_radius, gap_free_fraction):
    """The model's distance to the closest obstacles left and right when placed on their midpoint
    with the pose's heading (cosine c, sine s), if nothing lies nearer to the midpoint than
    gap_free_fraction of their half distance and they are farther apart than the model is wide;
    else inf."""
    ax, ay, bx, by = obstacles[left, 0], obstacles[left, 1], obstacles[right, 0], obstacles[right, 1]
    mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
    half = 0.5 * math.hypot(bx - ax, by - ay)
    to_mid2 = np.inf
    for j in keep:
        ex, ey = obstacles[j, 0] - mx, obstacles[j, 1] - my
        to_mid2 = min(to_mid2, ex * ex + ey * ey)
    clearance = min(footprint_distance_trig(mx, my, c, s, ax, ay, model)[0],
                    footprint_distance_trig(mx, my, c, s, bx, by, model)[0])
    if math.sqrt(to_mid2) >= gap_free_fraction * half and half > inscribed_radius and clearance > 0:
        return clearance
    return np.inf
