"""Constant-velocity Kalman filter over many tracks at once: state (x, y, vx, vy), one 4x4 covariance each."""

from __future__ import annotations

import numpy as np


def initial_covariance(count: int, position_sigma: float, speed_sigma: float) -> np.ndarray:
    return np.tile(np.diag([position_sigma ** 2, position_sigma ** 2, speed_sigma ** 2, speed_sigma ** 2]),
                   (count, 1, 1))


def predict(state: np.ndarray, cov: np.ndarray, dt: float, acceleration_sigma) -> None:
    """Advance (T, 4) states and (T, 4, 4) covariances by dt in place; white acceleration noise of
    acceleration_sigma, one for all tracks or one per track."""
    if dt <= 0.0 or not len(state):
        return
    state[:, 0:2] += dt * state[:, 2:4]
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    a, b, c = dt ** 4 / 4, dt ** 3 / 2, dt ** 2
    unit = np.array([[a, 0, b, 0], [0, a, 0, b], [b, 0, c, 0], [0, b, 0, c]])
    q = np.broadcast_to(np.square(np.asarray(acceleration_sigma, dtype=float)), (len(state),))
    cov[:] = f @ cov @ f.T + q[:, None, None] * unit


def update(state: np.ndarray, cov: np.ndarray, measured: np.ndarray, sigma: float) -> None:
    """Position measurements (M, 2) of M tracks (state (M, 4), cov (M, 4, 4), updated in place)."""
    if not len(state):
        return
    innovation_cov = cov[:, :2, :2] + np.eye(2) * sigma ** 2
    gain = cov[:, :, :2] @ np.linalg.inv(innovation_cov)                 # (M, 4, 2)
    state += (gain @ (measured - state[:, :2])[:, :, None])[:, :, 0]
    cov -= gain @ cov[:, :2, :]
    cov[:] = 0.5 * (cov + np.swapaxes(cov, 1, 2))                          # keep it symmetric


def speed_and_sigma(state: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each track's speed and the standard deviation of its speed along its velocity."""
    v = state[:, 2:4]
    speed = np.hypot(v[:, 0], v[:, 1])
    direction = np.where(speed[:, None] > 1e-9, v / np.maximum(speed, 1e-9)[:, None], np.array([1.0, 0.0]))
    variance = np.einsum("ti,tij,tj->t", direction, cov[:, 2:4, 2:4], direction)
    return speed, np.sqrt(np.maximum(variance, 0.0))
