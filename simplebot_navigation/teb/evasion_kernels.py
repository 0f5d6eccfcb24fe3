"""Compiled rollouts and contact check of the evasion (teb/evasion.py; its numpy contact_times is the
reference of rollout_contacts).

A crowd puts two dozen obstacles against some seventy rollouts of fifty poses each, every cycle that
evades; most pairs are metres apart, and a centre distance less the model's bounding radius settles
them without the footprint distance.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from simplebot_navigation.teb.footprint_kernels import footprint_distance_trig


@njit(cache=True, nogil=True)
def rollouts(x0, y0, th0, v0, w0, targets, acc_lim_x, acc_lim_theta, step, n):
    """Poses (S, n+1, 3): each target (S, 2) reached from (v0, w0) at the acceleration limits, then
    held; unicycle with the heading at the middle of each step."""
    out = np.empty((targets.shape[0], n + 1, 3))
    dv, dw = acc_lim_x * step, acc_lim_theta * step
    for s in range(targets.shape[0]):
        x, y, th, v, w = x0, y0, th0, v0, w0
        out[s, 0, 0], out[s, 0, 1], out[s, 0, 2] = x, y, th
        for k in range(1, n + 1):
            v += min(max(targets[s, 0] - v, -dv), dv)
            w += min(max(targets[s, 1] - w, -dw), dw)
            mid = th + 0.5 * w * step
            x += v * step * math.cos(mid)
            y += v * step * math.sin(mid)
            th += w * step
            out[s, k, 0], out[s, k, 1], out[s, k, 2] = x, y, th
    return out


@njit(cache=True, nogil=True)
def keep_out_radius(row, t, horizon, max_uncertainty, radius_growth):
    """perception/prediction.py MotionPrediction.radii for one prediction row at one time."""
    t = min(t, horizon)
    return (row[4] + min(math.hypot(row[5], t * row[6]), max_uncertainty)) + radius_growth * t


@njit(cache=True, nogil=True)
def rollout_contacts(poses, times, obstacles, model, bounding_radius, margin, closing, clearance_cap, horizon,
                     max_uncertainty, radius_growth):
    """For rollouts (S, N, 3) from one pose, timed (N,), obstacles (K, 7) prediction rows (x y vx vy radius and
    the position and velocity spreads, perception/prediction.py): the time of the first pose within ``margin``
    of an obstacle's keep-out circle, growing up to ``horizon`` and as large after it, or ``closing`` nearer than the
    first pose is to it if that is less (inf if none), and the smallest distance up to then, at most
    clearance_cap."""
    n_roll, n_pose = poses.shape[0], poses.shape[1]
    first = np.full(n_roll, np.inf)
    nearest = np.full(n_roll, clearance_cap)
    n_obst = obstacles.shape[0]
    radius = np.empty((n_pose, n_obst))
    for n in range(n_pose):
        for k in range(n_obst):
            radius[n, k] = keep_out_radius(obstacles[k], times[n], horizon, max_uncertainty, radius_growth)
    limit = np.empty(n_obst)
    c0, s0 = math.cos(poses[0, 0, 2]), math.sin(poses[0, 0, 2])
    for k in range(n_obst):
        now = footprint_distance_trig(poses[0, 0, 0], poses[0, 0, 1], c0, s0, obstacles[k, 0], obstacles[k, 1],
                                      model)[0] - radius[0, k]
        limit[k] = min(margin, now - closing)
    for s in range(n_roll):
        for n in range(n_pose):
            t = times[n]
            x, y, th = poses[s, n, 0], poses[s, n, 1], poses[s, n, 2]
            c, sn = math.cos(th), math.sin(th)
            for k in range(n_obst):
                ox = obstacles[k, 0] + t * obstacles[k, 2]
                oy = obstacles[k, 1] + t * obstacles[k, 3]
                bound = math.hypot(ox - x, oy - y) - radius[n, k] - bounding_radius
                if bound >= nearest[s] and bound >= limit[k]:
                    continue
                d = footprint_distance_trig(x, y, c, sn, ox, oy, model)[0] - radius[n, k]
                if d < nearest[s]:
                    nearest[s] = d
                if d < limit[k] and first[s] == np.inf:
                    first[s] = t
            if first[s] < np.inf:
                break
    return first, nearest
