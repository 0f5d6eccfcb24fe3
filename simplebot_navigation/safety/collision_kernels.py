"""Compiled geometry of the collision monitor: where the lidar points meet the robot's body.

Why numba: the monitor answers every velocity command (20 Hz), and the approach check places the
body at up to a few dozen future poses against every nearby point. As loops that stop at the first
step with contact, this costs microseconds; as numpy arrays (steps x points x edges) it cost a few
milliseconds per command, more than the 3 % of a core the monitor may use. A body is either a
polygon (``vertices`` (V, 2), ``radius`` 0) or a circle (``radius`` > 0) in the robot frame.
Compiled with ``cache=True``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from simplebot_navigation.geometry_kernels import inside_polygon


@njit(cache=True, nogil=True)
def inside_body(qx, qy, vertices, radius):
    """Distance for a circle, the even-odd rule for a polygon."""
    if radius > 0.0:
        return qx * qx + qy * qy <= radius * radius
    return inside_polygon(qx, qy, vertices)


@njit(cache=True, nogil=True)
def first_contact_step(points, velocities, moving_until, v, w, dt, steps, vertices, radius, reach, min_points):
    """The first of ``steps`` future poses (k * dt at the constant command v, w) at which at least
    ``min_points`` points that are outside the body now are inside it; -1 if none is.

    Point p moves on at ``velocities[p]`` (per unit of dt, in the frame of the robot's pose now) and counts only
    while k * dt < ``moving_until`` if it moves: a contact the robot would suffer standing still at that time is
    not one its command causes."""
    n = points.shape[0]
    outside = np.empty(n, dtype=np.bool_)
    moving = np.empty(n, dtype=np.bool_)
    for p in range(n):
        outside[p] = not inside_body(points[p, 0], points[p, 1], vertices, radius)
        moving[p] = velocities[p, 0] != 0.0 or velocities[p, 1] != 0.0
    reach2 = reach * reach
    for k in range(1, steps + 1):
        t = k * dt
        th = w * t
        if abs(w) > 1e-9:
            x = v / w * math.sin(th)
            y = v / w * (1.0 - math.cos(th))
        else:
            x = v * t
            y = 0.0
        c, s = math.cos(th), math.sin(th)
        hits = 0
        for p in range(n):
            if not outside[p] or (moving[p] and t >= moving_until):
                continue
            dx = points[p, 0] + velocities[p, 0] * t - x
            dy = points[p, 1] + velocities[p, 1] * t - y
            if dx * dx + dy * dy > reach2:
                continue
            if inside_body(c * dx + s * dy, -s * dx + c * dy, vertices, radius):
                hits += 1
                if hits >= min_points:
                    return k
    return -1
