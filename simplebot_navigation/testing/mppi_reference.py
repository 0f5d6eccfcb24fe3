"""Vectorised numpy versions of the MPPI kernels (mppi/kernels.py): the readable oracle the compiled loops are
tested against. The controller itself does not use them."""

from __future__ import annotations

import numpy as np

from simplebot_navigation.mppi import kernels as k


def rollout(state, sequence, noise, limits, dt):
    """kernels.rollout, every sample at once, step by step."""
    n_batch, n_steps = noise.shape[:2]
    commands = sequence[None] + noise
    controls, poses = np.empty((n_batch, n_steps, 2)), np.empty((n_batch, n_steps, 3))
    x, y, th = (np.full(n_batch, float(value)) for value in state[:3])
    v, w = np.full(n_batch, float(state[3])), np.full(n_batch, float(state[4]))
    for t in range(n_steps):
        vc = np.clip(commands[:, t, 0], limits[k.VX_MIN], limits[k.VX_MAX])
        wc = np.clip(commands[:, t, 1], -limits[k.WZ_MAX], limits[k.WZ_MAX])
        dv = vc - v
        step = np.where((v * dv > 0) | (v == 0), limits[k.AX_MAX] * dt, -limits[k.AX_MIN] * dt)
        dv = np.clip(dv, -step, step)
        dw = np.clip(wc - w, -limits[k.AZ_MAX] * dt, limits[k.AZ_MAX] * dt)
        wheel_change = np.abs(dv) + np.abs(dw) * limits[k.HALF_SEPARATION]
        ramp = np.minimum(1.0, limits[k.WHEEL_ACCEL] * dt / np.maximum(wheel_change, 1e-300))
        v, w = v + dv * ramp, w + dw * ramp
        scale = np.minimum(1.0, limits[k.WHEEL_MAX] / np.maximum(np.abs(v) + np.abs(w) * limits[k.HALF_SEPARATION],
                                                                 1e-300))
        v, w = v * scale, w * scale
        mid = th + 0.5 * w * dt
        x, y, th = x + v * dt * np.cos(mid), y + v * dt * np.sin(mid), th + w * dt
        controls[:, t] = np.column_stack([v, w])
        poses[:, t] = np.column_stack([x, y, th])
    return controls, poses


def _costs_at(grid, origin_x, origin_y, resolution, x, y):
    fx, fy = (x - origin_x) / resolution, (y - origin_y) / resolution
    on = (fx >= 0) & (fx < grid.shape[1]) & (fy >= 0) & (fy < grid.shape[0])
    cost = np.zeros(x.shape, dtype=int)
    cost[on] = grid[fy[on].astype(int), fx[on].astype(int)]
    return cost


def _first(hit: np.ndarray) -> np.ndarray:
    """Index of the first True per row, the row's length if none."""
    return np.where(hit.any(axis=1), np.argmax(hit, axis=1), hit.shape[1])


def costmap_terms(poses, grid, origin_x, origin_y, resolution, outline):
    """kernels.costmap_terms: every pose's centre and outline cells at once."""
    n_steps = poses.shape[1]
    cost = _costs_at(grid, origin_x, origin_y, resolution, poses[..., 0], poses[..., 1])
    hit = (cost == k.INSCRIBED) | (cost == k.LETHAL)
    near = (cost > 0) & (cost != k.UNKNOWN) & ~hit
    if len(outline):
        c, s = np.cos(poses[..., 2])[..., None], np.sin(poses[..., 2])[..., None]
        px = poses[..., 0:1] + c * outline[:, 0] - s * outline[:, 1]
        py = poses[..., 1:2] + s * outline[:, 0] + c * outline[:, 1]
        hit |= near & (_costs_at(grid, origin_x, origin_y, resolution, px, py) == k.LETHAL).any(axis=-1)
    first = _first(hit)
    before = np.arange(n_steps)[None] < first[:, None]
    return first, np.where(before & near, cost / 252.0, 0.0).sum(axis=1) / n_steps


def _clearances(poses, centres, radii, circles):
    """(B, T, K) distance of the body's circles at each pose to each obstacle's keep-out circle."""
    c, s = np.cos(poses[..., 2]), np.sin(poses[..., 2])
    cx = poses[..., 0, None] + c[..., None] * circles[:, 0] - s[..., None] * circles[:, 1]   # B, T, C
    cy = poses[..., 1, None] + s[..., None] * circles[:, 0] + c[..., None] * circles[:, 1]
    d = np.hypot(cx[..., None, :] - centres[..., 0, None], cy[..., None, :] - centres[..., 1, None]) - circles[:, 2]
    return d.min(axis=-1) - radii


def moving_terms(start, poses, centres, radii, circles, margin, closing, clearance):
    """kernels.moving_terms: every pose against every obstacle at once (no bounding-circle shortcut)."""
    n_batch, n_steps = poses.shape[:2]
    if centres.shape[1] == 0:
        return np.full(n_batch, n_steps), np.zeros(n_batch)
    d = _clearances(poses, centres[None, 1:], radii[None, 1:], circles)                    # B, T, K
    now = _clearances(np.asarray(start, float)[None, None], centres[None, :1], radii[None, :1], circles)[0, 0]
    first = _first((d < np.minimum(margin, now - closing)).any(axis=2))
    before = np.arange(n_steps)[None] < first[:, None]
    nearest = np.minimum(d.min(axis=2), max(clearance, margin))
    return first, np.where(before, np.maximum(0.0, clearance - nearest), 0.0).sum(axis=1) / n_steps


def path_terms(poses, controls, velocity, dt, path, target, goal):
    """kernels.path_terms, vectorised."""
    n_batch, n_steps = poses.shape[:2]
    strided = poses[:, ::k.STRIDE]
    out = np.zeros((n_batch, 6))
    out[:, k.ALIGN] = np.sqrt(((strided[..., None, :2] - path) ** 2).sum(-1).min(-1)).mean(1)
    out[:, k.FOLLOW] = np.hypot(*(target - poses[:, -1, :2]).T)
    error = np.arctan2(target[1] - strided[..., 1], target[0] - strided[..., 0]) - strided[..., 2]
    out[:, k.ANGLE] = np.abs(np.arctan2(np.sin(error), np.cos(error))).mean(1)
    out[:, k.GOAL] = np.hypot(goal[0] - strided[..., 0], goal[1] - strided[..., 1]).mean(1)
    out[:, k.REVERSE] = np.maximum(0.0, -controls[..., 0]).sum(1) * dt
    previous = np.concatenate([np.broadcast_to(np.asarray(velocity, float), (n_batch, 1, 2)), controls[:, :-1]], axis=1)
    out[:, k.SMOOTH] = (((controls - previous) / dt) ** 2).sum(-1).mean(1)
    return out


def guide_terms(poses, dt, guide):
    """kernels.guide_terms, vectorised."""
    strided = poses[:, ::k.STRIDE]
    times = (np.arange(poses.shape[1])[::k.STRIDE] + 1) * dt
    at = np.column_stack([np.interp(times, guide[:, 0], guide[:, 1]), np.interp(times, guide[:, 0], guide[:, 2])])
    return np.hypot(*(strided[..., :2] - at[None]).transpose(2, 0, 1)).mean(1)

