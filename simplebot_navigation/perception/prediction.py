"""Where a tracked obstacle will be, and how much room to leave it, some seconds ahead (docs/reference.md §4.8).

A track is a position and a velocity with the Kalman filter's covariance. It is predicted at constant velocity;
the circle to keep out of grows with the time ahead, up to a horizon, and stays as large after it:

    radius(t) = radius + min(max_uncertainty, sqrt(position_spread^2 + t^2 velocity_spread^2)) + radius_growth t

with t capped at the horizon in the radius, the spreads n_sigma standard deviations of position and velocity. Pure numpy, no
planner: TEB uses it (teb/obstacles.py), and so can any planner that reasons in space and time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.parameters import param

@dataclass(slots=True)
class KeepOutGrowth:
    """The parameters of the formula above, shared by every planner that predicts obstacles with it (each
    declares them in its own namespace under these names)."""
    dynamic_obstacle_radius_growth: float = param(0.0, "m/s", "Here: a predicted obstacle's radius grows by this "
                                                  "per second of prediction", ge=0, le=2.0)
    dynamic_obstacle_uncertainty_sigmas: float = param(2.0, "", "Here: a predicted obstacle's radius grows by this "
                                                       "many standard deviations of its tracked position and of "
                                                       "its velocity times the time ahead (0: none)", ge=0, le=5.0)
    dynamic_obstacle_max_uncertainty: float = param(0.1, "m", "Here: the most the uncertainty adds to a predicted "
                                                    "obstacle's radius", ge=0, le=2.0)
    dynamic_obstacle_prediction_horizon: float = param(4.0, "s", "Here: a moving obstacle's keep-out circle grows "
                                                       "with the time ahead up to this far, and stays as large "
                                                       "after it (0: no horizon)", ge=0, le=30.0)


#: Columns of a predicted obstacle's row: position and velocity (m, m/s), radius (m), and the n_sigma spreads of
#: position (m) and velocity (m/s).
X, Y, VX, VY, RADIUS, POSITION_SPREAD, VELOCITY_SPREAD = range(7)
COLUMNS = 7
#: Relative tolerance of the symmetry and positive semi-definiteness of a covariance (the filter's rounding).
COVARIANCE_TOLERANCE = 1e-9


def valid_covariances(covariance: np.ndarray) -> np.ndarray:
    """Mask of the (K, 4, 4) matrices that are covariances: finite, symmetric and positive semi-definite
    within COVARIANCE_TOLERANCE of their largest entry."""
    k = len(covariance)
    finite = np.isfinite(covariance).reshape(k, 16).all(axis=1)
    ok = np.zeros(k, dtype=bool)
    if not finite.any():
        return ok
    c = covariance[finite]
    scale = np.maximum(np.abs(c).reshape(len(c), 16).max(axis=1), 1.0)
    symmetric = np.abs(c - c.transpose(0, 2, 1)).reshape(len(c), 16).max(axis=1) <= COVARIANCE_TOLERANCE * scale
    lowest = np.linalg.eigvalsh(0.5 * (c + c.transpose(0, 2, 1)))[:, 0]
    ok[finite] = symmetric & (lowest >= -COVARIANCE_TOLERANCE * scale)
    return ok


def largest_sigma(block: np.ndarray) -> np.ndarray:
    """Standard deviation along the most uncertain direction of each (K, 2, 2) covariance block: the square root
    of its largest eigenvalue, in closed form."""
    a, b, d = block[:, 0, 0], 0.5 * (block[:, 0, 1] + block[:, 1, 0]), block[:, 1, 1]
    return np.sqrt(np.maximum(0.5 * (a + d) + np.hypot(0.5 * (a - d), b), 0.0))


def prediction_rows(obstacles: np.ndarray, covariance: np.ndarray | None, n_sigma: float) -> np.ndarray:
    """(K, COLUMNS) rows from (K, 5) rows x, y, vx, vy, radius and their (K, 4, 4) covariances over x, y, vx, vy
    (None: none known, spreads zero). The spread is isotropic, the largest sigma of each block: a circle whose
    size does not depend on where the robot is keeps the optimiser's edges functions of the pose alone, and it
    is a property of the obstacle that any planner can share."""
    rows = np.zeros((len(obstacles), COLUMNS))
    rows[:, :5] = obstacles
    if covariance is not None and len(obstacles):
        rows[:, POSITION_SPREAD] = n_sigma * largest_sigma(covariance[:, :2, :2])
        rows[:, VELOCITY_SPREAD] = n_sigma * largest_sigma(covariance[:, 2:, 2:])
    return rows


def full_rows(rows: np.ndarray) -> np.ndarray:
    """Rows of COLUMNS columns: (K, 5) rows x, y, vx, vy, radius get zero spreads."""
    rows = np.asarray(rows, dtype=float)
    if rows.shape[1] == COLUMNS:
        return rows
    return prediction_rows(rows[:, :5], None, 0.0)


@dataclass(frozen=True)
class MotionPrediction:
    """The prediction's settings: the horizon (s, inf: none) after which the keep-out circle stops growing, the
    cap on the uncertainty's extra radius (m) and a growth of the radius per second ahead (m/s) on top of it,
    whatever the covariance."""
    horizon: float = math.inf
    max_uncertainty: float = math.inf
    radius_growth: float = 0.0

    def centres(self, rows: np.ndarray, times) -> np.ndarray:
        """(K, T, 2): each obstacle's centre at each time, at constant velocity (beyond the horizon too: one held
        where it is at the horizon stands in the prediction where it will not be, and a band passing behind it
        there runs into it later)."""
        t = np.asarray(times, dtype=float)
        return rows[:, None, X:Y + 1] + t[None, :, None] * rows[:, None, VX:VY + 1]

    def radii(self, rows: np.ndarray, times) -> np.ndarray:
        """(K, T): each obstacle's keep-out radius at each time, as large after the horizon as at it."""
        rows = full_rows(rows)
        t = np.minimum(np.asarray(times, dtype=float), self.horizon)[None, :]
        spread = np.hypot(rows[:, POSITION_SPREAD, None], t * rows[:, VELOCITY_SPREAD, None])
        return rows[:, RADIUS, None] + np.minimum(spread, self.max_uncertainty) + self.radius_growth * t

    def table(self, rows: np.ndarray, dt: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """Centres (steps + 1, K, 2) and radii (steps + 1, K) at times 0, dt, ... steps dt: what a compiled loop
        over a horizon of time steps reads, whatever the prediction (a subclass's centres and radii)."""
        times = np.arange(steps + 1) * dt
        return (np.ascontiguousarray(self.centres(rows, times).transpose(1, 0, 2), dtype=float),
                np.ascontiguousarray(self.radii(rows, times).T, dtype=float))

    @property
    def kernel_arguments(self) -> tuple[float, float, float]:
        """(horizon, max_uncertainty, radius_growth) for a compiled loop."""
        return float(self.horizon), float(self.max_uncertainty), float(self.radius_growth)


#: a moving obstacle is a person or a robot: its radius at most this (m), its speed at most MAX_SPEED_M_S and its
#: position within MAX_COORDINATE_M of the frame's origin; a row beyond is not a real obstacle, and its squares
#: would overflow the planners' arithmetic (obstacle_msgs.py refuses the same in another node's message)
MAX_RADIUS_M = 5.0
MAX_SPEED_M_S = 10.0
MAX_COORDINATE_M = 1e4


def checked_dynamic_obstacles(obstacles, covariance=None) -> tuple[np.ndarray, np.ndarray | None, str]:
    """set_dynamic_obstacles' input checked: (K, 5) rows x, y, vx, vy, radius and None or (K, 4, 4)
    covariances over x, y, vx, vy. A wrong shape raises ValueError; rows with a non-finite value, a negative
    radius or a value beyond the bounds above, or whose covariance is not one (valid_covariances), are dropped. Returns the kept rows,
    their covariances and what was dropped ("" if nothing)."""
    rows = np.asarray(obstacles, dtype=float)
    if rows.size == 0:
        rows = rows.reshape(0, 5)
    if rows.ndim != 2 or rows.shape[1] != 5:
        raise ValueError(f"dynamic obstacles must be a (K, 5) array of x, y, vx, vy, radius; got shape {rows.shape}")
    valid = np.isfinite(rows).all(axis=1) & (rows[:, 4] >= 0)
    dropped = []
    if not valid.all():
        dropped.append(f"{np.count_nonzero(~valid)} with a non-finite value or a negative radius")
    with np.errstate(invalid="ignore", over="ignore"):
        beyond = valid & ((np.abs(rows[:, :2]) > MAX_COORDINATE_M).any(axis=1) | (rows[:, 4] > MAX_RADIUS_M)
                          | (np.hypot(rows[:, 2], rows[:, 3]) > MAX_SPEED_M_S))
    if beyond.any():
        dropped.append(f"{np.count_nonzero(beyond)} beyond {MAX_COORDINATE_M:g} m from the origin, a radius of "
                       f"{MAX_RADIUS_M:g} m or a speed of {MAX_SPEED_M_S:g} m/s")
    valid &= ~beyond
    cov = None
    if covariance is not None:
        cov = np.asarray(covariance, dtype=float)
        if cov.size == 0 and len(rows) == 0:
            cov = cov.reshape(0, 4, 4)
        if cov.shape != (len(rows), 4, 4):
            raise ValueError(f"dynamic obstacle covariances must be a (K, 4, 4) array over x, y, vx, vy for the "
                             f"{len(rows)} obstacles; got shape {cov.shape}")
        bad = ~valid_covariances(cov) & valid
        if bad.any():
            dropped.append(f"{np.count_nonzero(bad)} whose covariance is not finite, symmetric and positive "
                           "semi-definite")
        valid &= ~bad
        cov = cov[valid].copy()
    what = f"{np.count_nonzero(~valid)} of {len(rows)} dynamic obstacles ({', '.join(dropped)})" if dropped else ""
    return rows[valid].copy(), cov, what
