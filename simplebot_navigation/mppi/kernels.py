"""Compiled hot loops of the MPPI controller: the motion model over every sampled sequence and the critics that
look at every pose of every rollout. Their numpy references are in simplebot_navigation/testing/mppi_reference.py.

A thousand rollouts of sixty steps are sixty thousand poses a cycle, each looked up in the costmap and set against
two dozen moving obstacles: numpy's temporaries for that cost more than the cycle has, loops compiled by numba
(``cache=True``, GIL released) do not.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: columns of the limits vector the motion model takes (MotionLimits.vector in motion.py)
VX_MIN, VX_MAX, WZ_MAX, AX_MAX, AX_MIN, AZ_MAX, WHEEL_MAX, HALF_SEPARATION, WHEEL_ACCEL = range(9)
#: costmap values (costmap/cost_values.py): inscribed and lethal cells are infeasible, unknown costs nothing
INSCRIBED, LETHAL, UNKNOWN = 253, 254, 255
#: columns of path_terms: PathAlign, PathFollow, PathAngle, Goal, reverse travel, smoothness
ALIGN, FOLLOW, ANGLE, GOAL, REVERSE, SMOOTH = range(6)
#: path critics look at every STRIDE-th pose (Nav2's trajectory_point_step)
STRIDE = 3


@njit(cache=True, nogil=True)
def step_velocity(v, w, vc, wc, limits, dt):
    """The velocity after one step towards the command (vc, wc): the command held to the velocity limits, the
    change to the acceleration limits (ax_max away from standstill, ax_min towards it, az_max), both changes scaled
    by one factor so that no wheel changes speed faster than wheel_accel_max (the drive ramps its wheels so), then
    the wheel speeds to wheel_speed_max along the curvature, as the drive saturates."""
    vc = min(max(vc, limits[VX_MIN]), limits[VX_MAX])
    wc = min(max(wc, -limits[WZ_MAX]), limits[WZ_MAX])
    dv = vc - v
    step = limits[AX_MAX] * dt if (v * dv > 0.0 or v == 0.0) else -limits[AX_MIN] * dt
    dv = min(max(dv, -step), step)
    turn = limits[AZ_MAX] * dt
    dw = min(max(wc - w, -turn), turn)
    wheel_change = abs(dv) + abs(dw) * limits[HALF_SEPARATION]
    if wheel_change > limits[WHEEL_ACCEL] * dt:
        scale = limits[WHEEL_ACCEL] * dt / wheel_change
        dv *= scale
        dw *= scale
    v += dv
    w += dw
    wheel = abs(v) + abs(w) * limits[HALF_SEPARATION]
    if wheel > limits[WHEEL_MAX]:
        scale = limits[WHEEL_MAX] / wheel
        v *= scale
        w *= scale
    return v, w


@njit(cache=True, nogil=True)
def rollout(state, sequence, noise, limits, dt):
    """Controls (B, T, 2) and poses (B, T, 3) of the sequence (T, 2) plus each noise row (B, T, 2), from state
    (x, y, yaw, v, w): pose t is where control t, held for dt, leaves the robot (heading at mid-step)."""
    n_batch, n_steps = noise.shape[0], noise.shape[1]
    controls = np.empty((n_batch, n_steps, 2))
    poses = np.empty((n_batch, n_steps, 3))
    for b in range(n_batch):
        x, y, th, v, w = state[0], state[1], state[2], state[3], state[4]
        for t in range(n_steps):
            v, w = step_velocity(v, w, sequence[t, 0] + noise[b, t, 0], sequence[t, 1] + noise[b, t, 1], limits, dt)
            mid = th + 0.5 * w * dt
            x += v * dt * math.cos(mid)
            y += v * dt * math.sin(mid)
            th += w * dt
            controls[b, t, 0], controls[b, t, 1] = v, w
            poses[b, t, 0], poses[b, t, 1], poses[b, t, 2] = x, y, th
    return controls, poses


@njit(cache=True, nogil=True)
def cell_cost(grid, origin_x, origin_y, resolution, x, y):
    """The cost of the cell under (x, y); 0 off the map (the rolling window knows nothing there)."""
    fx = (x - origin_x) / resolution
    fy = (y - origin_y) / resolution
    if not (0.0 <= fx < grid.shape[1] and 0.0 <= fy < grid.shape[0]):
        return 0
    return grid[int(fy), int(fx)]


@njit(cache=True, nogil=True)
def costmap_terms(poses, grid, origin_x, origin_y, resolution, outline):
    """Per rollout (B, T, 3): the index of the first pose in collision (T: none) and the mean cost / 252 of the
    poses before it. A pose collides when its centre cell is inscribed or lethal, or when a point of ``outline``
    ((P, 2) in the robot frame; empty for a round body, whose inscribed cost says it all) lies in a lethal cell;
    the outline is looked at only where the centre has some cost, i.e. near an obstacle. Unknown cells cost
    nothing."""
    n_batch, n_steps = poses.shape[0], poses.shape[1]
    first = np.full(n_batch, n_steps, dtype=np.int64)
    mean = np.zeros(n_batch)
    for b in range(n_batch):
        total = 0.0
        for t in range(n_steps):
            x, y, th = poses[b, t, 0], poses[b, t, 1], poses[b, t, 2]
            cost = cell_cost(grid, origin_x, origin_y, resolution, x, y)
            hit = cost == INSCRIBED or cost == LETHAL
            near = not hit and cost > 0 and cost != UNKNOWN
            if near:
                c, s = math.cos(th), math.sin(th)
                for p in range(outline.shape[0]):
                    px = x + c * outline[p, 0] - s * outline[p, 1]
                    py = y + s * outline[p, 0] + c * outline[p, 1]
                    if cell_cost(grid, origin_x, origin_y, resolution, px, py) == LETHAL:
                        hit = True
                        break
            if hit:
                first[b] = t
                break
            if near:
                total += cost / 252.0
        mean[b] = total / n_steps
    return first, mean


@njit(cache=True, nogil=True)
def body_clearance(x, y, c, s, ox, oy, circles):
    """Distance from the body's circles (C, 3: cx, cy, r in the robot frame) at pose (x, y, cos, sin) to a point."""
    best = np.inf
    for i in range(circles.shape[0]):
        cx = x + c * circles[i, 0] - s * circles[i, 1]
        cy = y + s * circles[i, 0] + c * circles[i, 1]
        best = min(best, math.hypot(ox - cx, oy - cy) - circles[i, 2])
    return best


@njit(cache=True, nogil=True)
def moving_terms(start, poses, centres, radii, circles, margin, closing, clearance):
    """Per rollout (B, T, 3; pose t at time (t + 1) dt) against moving obstacles where they are predicted to be:
    ``centres`` (T + 1, K, 2) and keep-out ``radii`` (T + 1, K) at times 0, dt, ... T dt (the prediction's
    table, Prediction.table). Returns the index of the first pose within ``margin`` of a keep-out circle (T: none),
    or ``closing`` nearer than the body at ``start`` (x, y, yaw at time 0) is to it, if that is less (one that cut
    in close can still be left); and the mean shortfall of the clearance below ``clearance`` over the poses before
    it.

    Only the obstacles that can come within ``clearance`` of some rollout at step t are looked at then: those near
    the box round all the rollouts' poses of that step (most of a crowd is out of reach for most of the
    horizon), and of those only the ones whose bounding circle comes that near the pose."""
    n_batch, n_steps, n_obst = poses.shape[0], poses.shape[1], centres.shape[1]
    first = np.full(n_batch, n_steps, dtype=np.int64)
    shortfall = np.zeros(n_batch)
    if n_obst == 0:
        return first, shortfall
    reach = 0.0
    for i in range(circles.shape[0]):
        reach = max(reach, math.hypot(circles[i, 0], circles[i, 1]) + circles[i, 2])
    far = max(clearance, margin)
    # per step: which obstacles may matter to any rollout
    near2 = np.empty((n_steps, n_obst))
    candidates, counts = np.empty((n_steps, n_obst), dtype=np.int64), np.zeros(n_steps, dtype=np.int64)
    for t in range(n_steps):
        x_lo = x_hi = poses[0, t, 0]
        y_lo = y_hi = poses[0, t, 1]
        for b in range(1, n_batch):
            x_lo, x_hi = min(x_lo, poses[b, t, 0]), max(x_hi, poses[b, t, 0])
            y_lo, y_hi = min(y_lo, poses[b, t, 1]), max(y_hi, poses[b, t, 1])
        for k in range(n_obst):
            ox, oy = centres[t + 1, k, 0], centres[t + 1, k, 1]
            near2[t, k] = (far + reach + radii[t + 1, k]) ** 2
            gap_x = max(x_lo - ox, ox - x_hi, 0.0)
            gap_y = max(y_lo - oy, oy - y_hi, 0.0)
            if gap_x * gap_x + gap_y * gap_y < near2[t, k]:
                candidates[t, counts[t]] = k
                counts[t] += 1
    limit = np.empty(n_obst)
    c0, s0 = math.cos(start[2]), math.sin(start[2])
    for k in range(n_obst):
        now = body_clearance(start[0], start[1], c0, s0, centres[0, k, 0], centres[0, k, 1], circles) - radii[0, k]
        limit[k] = min(margin, now - closing)
    for b in range(n_batch):
        total = 0.0
        for t in range(n_steps):
            x, y, th = poses[b, t, 0], poses[b, t, 1], poses[b, t, 2]
            hit, nearest = False, far
            if counts[t]:
                c, s = math.cos(th), math.sin(th)
                for j in range(counts[t]):
                    k = candidates[t, j]
                    ox, oy = centres[t + 1, k, 0], centres[t + 1, k, 1]
                    dx, dy = ox - x, oy - y
                    if dx * dx + dy * dy >= near2[t, k]:
                        continue
                    d = body_clearance(x, y, c, s, ox, oy, circles) - radii[t + 1, k]
                    nearest = min(nearest, d)
                    if d < limit[k]:
                        hit = True
            if hit:
                first[b] = t
                break
            total += max(0.0, clearance - nearest)
        shortfall[b] = total / n_steps
    return first, shortfall


@njit(cache=True, nogil=True)
def path_terms(poses, controls, velocity, dt, path, target, goal):
    """The raw terms of the path and goal critics per rollout, columns ALIGN ... SMOOTH: mean distance of every
    STRIDE-th pose to the nearest path point (M, 2); distance from the last pose to ``target``; mean heading error
    towards ``target`` of every STRIDE-th pose; mean distance of every STRIDE-th pose to ``goal``; metres driven
    in reverse; mean squared acceleration (from ``velocity``, the robot's (v, w))."""
    n_batch, n_steps = poses.shape[0], poses.shape[1]
    out = np.zeros((n_batch, 6))
    n_strided = (n_steps + STRIDE - 1) // STRIDE
    for b in range(n_batch):
        align = angle = to_goal = 0.0
        for t in range(0, n_steps, STRIDE):
            x, y = poses[b, t, 0], poses[b, t, 1]
            best = np.inf
            for m in range(path.shape[0]):
                best = min(best, (path[m, 0] - x) ** 2 + (path[m, 1] - y) ** 2)
            align += math.sqrt(best)
            error = math.atan2(target[1] - y, target[0] - x) - poses[b, t, 2]
            angle += abs(math.atan2(math.sin(error), math.cos(error)))
            to_goal += math.hypot(goal[0] - x, goal[1] - y)
        reverse = smooth = 0.0
        v, w = velocity[0], velocity[1]
        for t in range(n_steps):
            reverse += max(0.0, -controls[b, t, 0]) * dt
            smooth += ((controls[b, t, 0] - v) / dt) ** 2 + ((controls[b, t, 1] - w) / dt) ** 2
            v, w = controls[b, t, 0], controls[b, t, 1]
        last = n_steps - 1
        out[b, ALIGN] = align / n_strided
        out[b, FOLLOW] = math.hypot(target[0] - poses[b, last, 0], target[1] - poses[b, last, 1])
        out[b, ANGLE] = angle / n_strided
        out[b, GOAL] = to_goal / n_strided
        out[b, REVERSE] = reverse
        out[b, SMOOTH] = smooth / n_steps
    return out


@njit(cache=True, nogil=True)
def guide_terms(poses, dt, guide):
    """Per rollout (B, T, 3; pose t at time (t + 1) dt): the mean distance of every STRIDE-th pose from where the
    space-time guide ((G, 3) rows t, x, y; held at its ends) is at the pose's time."""
    n_batch, n_steps = poses.shape[0], poses.shape[1]
    out = np.zeros(n_batch)
    n_strided = (n_steps + STRIDE - 1) // STRIDE
    times = (np.arange(0, n_steps, STRIDE) + 1) * dt
    gx = np.interp(times, guide[:, 0], guide[:, 1])
    gy = np.interp(times, guide[:, 0], guide[:, 2])
    for b in range(n_batch):
        total = 0.0
        for i in range(n_strided):
            t = i * STRIDE
            total += math.hypot(poses[b, t, 0] - gx[i], poses[b, t, 1] - gy[i])
        out[b] = total / n_strided
    return out


@njit(cache=True, nogil=True)
def unseen_first(poses, controls, dt, distance, origin_x, origin_y, resolution, circles, speed, closing):
    """Per manoeuvre (B, T): the index of the first pose, while the robot still moves, at which a lethal cell could
    reach the body if it were an obstacle the tracker has not seen, walking towards it at ``speed`` from time 0
    (T: none). ``distance`` holds each cell's distance to the nearest lethal cell; a body that starts closer than
    that allows only has to keep ``closing`` short of its clearance at time 0."""
    n_batch, n_steps = poses.shape[0], poses.shape[1]
    first = np.full(n_batch, n_steps, dtype=np.int64)
    for b in range(n_batch):
        start = np.inf
        for t in range(n_steps):
            if abs(controls[b, t, 0]) <= 1e-6 and abs(controls[b, t, 1]) <= 1e-6:
                break
            c, s = math.cos(poses[b, t, 2]), math.sin(poses[b, t, 2])
            clear = np.inf
            for i in range(circles.shape[0]):
                x = poses[b, t, 0] + c * circles[i, 0] - s * circles[i, 1]
                y = poses[b, t, 1] + s * circles[i, 0] + c * circles[i, 1]
                fx, fy = (x - origin_x) / resolution, (y - origin_y) / resolution
                if 0.0 <= fx < distance.shape[1] and 0.0 <= fy < distance.shape[0]:
                    clear = min(clear, distance[int(fy), int(fx)] - circles[i, 2])
            if t == 0:
                start = clear
            if clear < min(speed * (t + 1) * dt, start - closing):
                first[b] = t
                break
    return first
