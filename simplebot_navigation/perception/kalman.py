"""An interacting multiple model (IMM) filter over many tracks at once (docs/reference.md §6).

Each track has state (x, y, vx, vy) under MODELS motion models, one state and 4x4 covariance per model, and the
models' probabilities:

- STOPPED: the obstacle stands; its velocity is zero (static things, a person who stopped);
- STEADY: constant velocity with low white acceleration noise (walking on);
- MANOEUVRE: constant velocity with high acceleration noise (turning, speeding up, slowing down).

Every step mixes the models' estimates by a Markov chain of switches, predicts each, weighs each by how well it
predicted the measurement, and combines them into one state and covariance; the spread between the models' means
adds to the combined covariance, so that a track whose models disagree reports an uncertain velocity.
"""

from __future__ import annotations

import numpy as np

from simplebot_navigation.perception.tracking_kernels import imm_combine

STOPPED, STEADY, MANOEUVRE = range(3)
MODELS = 3
#: mean time a track keeps its motion model, seconds: the Markov chain's switching rate
MODEL_DWELL_S = 1.0
#: model probabilities of a track whose velocity was just set from two sightings
INITIAL_PROBABILITY = np.array([0.2, 0.5, 0.3])
#: the stopped model: how far a standing obstacle's centre drifts (m per sqrt(s)) and its velocity's sigma (m/s)
STOPPED_DRIFT = 0.02
STOPPED_SPEED_SIGMA = 0.02


def _unit_noise(dt: float) -> np.ndarray:
    """Covariance of white acceleration of unit density over dt, for (x, y, vx, vy)."""
    a, b, c = dt ** 3 / 3, dt ** 2 / 2, dt
    return np.array([[a, 0, b, 0], [0, a, 0, b], [b, 0, c, 0], [0, b, 0, c]])


def _constant_velocity(dt: float) -> np.ndarray:
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    return f


def transitions(dt: float) -> np.ndarray:
    """(MODELS, MODELS) probability of switching from model i (row) to j (column) within dt."""
    stay = np.exp(-dt / MODEL_DWELL_S)
    out = np.full((MODELS, MODELS), (1.0 - stay) / (MODELS - 1))
    np.fill_diagonal(out, stay)
    return out


def model_matrices(dt: float, steady_noise: float, manoeuvre_noise: float) -> tuple[np.ndarray, ...]:
    """The switching matrix (MODELS, MODELS) and each model's transition and process noise (MODELS, 4, 4) over dt."""
    f = np.stack([np.diag([1.0, 1.0, 0.0, 0.0]), _constant_velocity(dt), _constant_velocity(dt)])
    q = np.stack([np.diag([STOPPED_DRIFT ** 2 * dt] * 2 + [STOPPED_SPEED_SIGMA ** 2] * 2),
                  steady_noise ** 2 * _unit_noise(dt), manoeuvre_noise ** 2 * _unit_noise(dt)])
    return transitions(dt), f, q


def predict(states: np.ndarray, covs: np.ndarray, probs: np.ndarray, dt: float, steady_noise: float,
            manoeuvre_noise: float) -> None:
    """Mix and advance (T, M, 4) states, (T, M, 4, 4) covariances and (T, M) probabilities by dt, in place;
    steady_noise and manoeuvre_noise: the two moving models' acceleration sigmas (m/s^2)."""
    if dt <= 0.0 or not len(states):
        return
    switch, f, q = model_matrices(dt, steady_noise, manoeuvre_noise)
    predicted = probs @ switch                                                   # (T, M)
    weights = probs[:, :, None] * switch[None] / np.maximum(predicted[:, None, :], 1e-300)   # (T, i, j)
    mixed = np.einsum("tij,tik->tjk", weights, states)
    spread = states[:, :, None, :] - mixed[:, None, :, :]                       # (T, i, j, 4)
    mixed_cov = np.einsum("tij,tikl->tjkl", weights, covs) + \
        np.einsum("tij,tijk,tijl->tjkl", weights, spread, spread)
    states[:] = np.einsum("mij,tmj->tmi", f, mixed)
    covs[:] = f @ mixed_cov @ np.swapaxes(f, 1, 2) + q
    probs[:] = predicted


def update(states: np.ndarray, covs: np.ndarray, probs: np.ndarray, measured: np.ndarray,
           noise: np.ndarray) -> None:
    """Position measurements (T, 2) with covariances (T, 2, 2) of T tracks, updated in place."""
    if not len(states):
        return
    innovation = measured[:, None, :] - states[:, :, :2]                        # (T, M, 2)
    s = covs[:, :, :2, :2] + noise[:, None]
    det = s[..., 0, 0] * s[..., 1, 1] - s[..., 0, 1] * s[..., 1, 0]
    inverse = np.stack([np.stack([s[..., 1, 1], -s[..., 0, 1]], -1),
                        np.stack([-s[..., 1, 0], s[..., 0, 0]], -1)], -2) / det[..., None, None]
    gain = covs[:, :, :, :2] @ inverse                                           # (T, M, 4, 2)
    states += np.einsum("tmij,tmj->tmi", gain, innovation)
    covs -= gain @ covs[:, :, :2, :]
    covs[:] = 0.5 * (covs + np.swapaxes(covs, 2, 3))
    log_likelihood = -0.5 * np.einsum("tmi,tmij,tmj->tm", innovation, inverse, innovation) - 0.5 * np.log(det)
    weighted = probs * np.exp(log_likelihood - log_likelihood.max(axis=1, keepdims=True))
    probs[:] = weighted / np.maximum(weighted.sum(axis=1, keepdims=True), 1e-300)


def combine(states: np.ndarray, covs: np.ndarray, probs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One (T, 4) state and (T, 4, 4) covariance per track from its models'."""
    state = np.einsum("tm,tmi->ti", probs, states)
    spread = states - state[:, None, :]
    cov = np.einsum("tm,tmij->tij", probs, covs) + np.einsum("tm,tmi,tmj->tij", probs, spread, spread)
    return state, cov


def from_two_sightings(previous: np.ndarray, previous_cov: np.ndarray, measured: np.ndarray, noise: np.ndarray,
                       dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T, 4) states and (T, 4, 4) covariances from an earlier position (T, 2) with covariance (T, 2, 2) and a
    measurement (T, 2) with covariance (T, 2, 2) dt (T,) later: the velocity is the displacement over dt."""
    d = dt[:, None, None]
    state = np.column_stack([measured, (measured - previous) / dt[:, None]])
    cov = np.empty((len(dt), 4, 4))
    cov[:, :2, :2] = noise
    cov[:, :2, 2:] = noise / d
    cov[:, 2:, :2] = noise / d
    cov[:, 2:, 2:] = (noise + previous_cov) / d ** 2
    return state, cov


def extrapolate(state: np.ndarray, cov: np.ndarray, dt: float, acceleration_sigma: float) -> tuple[np.ndarray,
                                                                                                     np.ndarray]:
    """(T, 4) states and covariances dt ahead at constant velocity, with white acceleration noise."""
    if dt <= 0.0:
        return state.copy(), cov.copy()
    f = _constant_velocity(dt)
    return state @ f.T, f @ cov @ f.T + acceleration_sigma ** 2 * _unit_noise(dt)


def speed_and_sigma(state: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each track's speed and the standard deviation of its speed along its velocity."""
    v = state[:, 2:4]
    speed = np.hypot(v[:, 0], v[:, 1])
    direction = np.where(speed[:, None] > 1e-9, v / np.maximum(speed, 1e-9)[:, None], np.array([1.0, 0.0]))
    variance = np.einsum("ti,tij,tj->t", direction, cov[:, 2:4, 2:4], direction)
    return speed, np.sqrt(np.maximum(variance, 0.0))


def moving_speed_and_sigma(states: np.ndarray, covs: np.ndarray, probs: np.ndarray) -> tuple[np.ndarray, ...]:
    """Each track's speed and its sigma (along the velocity) by the moving models alone, and the stopped model's
    probability: whether it moves is judged by these, so that the spread between "stopped" and "moving" at the
    start (which the combined covariance holds) does not hide a clear motion."""
    moving = probs[:, STEADY:] / np.maximum(probs[:, STEADY:].sum(axis=1, keepdims=True), 1e-300)
    speed, sigma = speed_and_sigma(*imm_combine(np.ascontiguousarray(states[:, STEADY:]),
                                                np.ascontiguousarray(covs[:, STEADY:]), moving))
    return speed, sigma, probs[:, STOPPED]
