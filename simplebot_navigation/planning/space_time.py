"""Space-time reachability of a disc robot among moving discs: the earliest arrival, and whether there is one.

The search grows, one time step at a time, the set of grid cells the robot's centre can occupy at that step
without touching anything: last step's set, dilated by how far the robot can move in a step, minus the cells the
static world or any obstacle blocks at the new step (a wavefront in x, y and t; waiting is a move of length 0).
The first step whose set meets the goal region is the earliest arrival. With the obstacles' true future this is a
limit no planner of the same speed and clearance can beat, and an empty set means no such planner gets through.

The model is holonomic with instant acceleration (a diff-drive robot that must turn first arrives later), so the
arrival is a lower bound. Continuous time is covered conservatively: a step is two grid cells of robot travel, and
every obstacle is grown by half of what it and the robot can move in a step, so a robot clear of it at both ends of
a step is clear in between.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import ndimage

#: cells the robot's centre moves per time step (the dilation's radius)
STEP_CELLS = 2
_DISC = (np.hypot(*np.mgrid[-STEP_CELLS:STEP_CELLS + 1, -STEP_CELLS:STEP_CELLS + 1]) <= STEP_CELLS + 1e-9)


@dataclass(frozen=True)
class MovingDiscs:
    """The obstacles at one time: centres (n, 2), radii (n,) and speeds (n,), in the grid's frame."""
    centres: np.ndarray
    radii: np.ndarray
    speeds: np.ndarray


@dataclass(frozen=True)
class Arrival:
    """``arrival_s``: the earliest time the robot's centre is in the goal region (inf when it is never within the
    horizon); ``reachable_cells``: how many cells the last step's set held (0: the robot was caught, wherever it
    went)."""
    arrival_s: float
    steps: int
    reachable_cells: int

    @property
    def solvable(self) -> bool:
        return math.isfinite(self.arrival_s)


class SpaceTimeSearch:
    """A wavefront over one static grid: ``free`` (rows = y, cols = x) marks the cells where the robot's centre
    may stand among the static obstacles (already grown by the robot's radius and clearance), ``origin`` is the
    (x, y) of cell (0, 0)'s corner, ``resolution`` the cell size in metres."""

    def __init__(self, free: np.ndarray, origin: tuple[float, float], resolution: float):
        self.free = np.asarray(free, dtype=bool)
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution = float(resolution)
        rows, cols = np.indices(self.free.shape)
        self._x = self.origin[0] + (cols + 0.5) * self.resolution
        self._y = self.origin[1] + (rows + 0.5) * self.resolution

    def step_s(self, speed: float) -> float:
        """The time step at ``speed``: STEP_CELLS cells of travel."""
        return STEP_CELLS * self.resolution / speed

    def cell(self, x: float, y: float) -> tuple[int, int] | None:
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        if 0 <= row < self.free.shape[0] and 0 <= col < self.free.shape[1]:
            return row, col
        return None

    def blocked(self, discs: MovingDiscs, grow: np.ndarray) -> np.ndarray:
        """Cells whose centre lies within each disc's radius plus its ``grow`` (per disc, metres)."""
        out = np.zeros(self.free.shape, dtype=bool)
        h, (x0, y0) = self.resolution, self.origin
        for (cx, cy), reach in zip(discs.centres, discs.radii + grow):
            r0 = max(math.floor((cy - reach - y0) / h), 0)
            r1 = min(math.ceil((cy + reach - y0) / h) + 1, out.shape[0])
            c0 = max(math.floor((cx - reach - x0) / h), 0)
            c1 = min(math.ceil((cx + reach - x0) / h) + 1, out.shape[1])
            if r0 >= r1 or c0 >= c1:
                continue
            dx, dy = self._x[r0:r1, c0:c1] - cx, self._y[r0:r1, c0:c1] - cy
            out[r0:r1, c0:c1] |= dx * dx + dy * dy <= reach * reach
        return out

    def earliest_arrival(self, start: tuple[float, float], goal: tuple[float, float], goal_radius: float,
                         speed: float, discs_at: Callable[[float], MovingDiscs], t0: float, horizon_s: float,
                         clearance: float = 0.0) -> Arrival:
        """From ``start`` at time ``t0``, the first time within ``horizon_s`` the robot's centre can be within
        ``goal_radius`` of ``goal`` at ``speed`` m/s, staying ``clearance`` m beyond every moving disc
        (``discs_at(t)``, radii being each obstacle's plus the robot's)."""
        if not speed > 0:
            raise ValueError(f"speed must be > 0, got {speed}")
        dt = self.step_s(speed)
        goal_region = self.free & (np.hypot(self._x - goal[0], self._y - goal[1]) <= goal_radius)
        start_cell = self.cell(*start)
        reach = np.zeros(self.free.shape, dtype=bool)
        if start_cell is None:
            return Arrival(math.inf, 0, 0)

        def clear_at(t: float) -> np.ndarray:
            discs = discs_at(t)
            return self.free & ~self.blocked(discs, clearance + 0.5 * dt * (discs.speeds + speed))

        reach[start_cell] = clear_at(t0)[start_cell]
        steps = int(math.ceil(horizon_s / dt))
        for k in range(steps + 1):
            if not reach.any():
                return Arrival(math.inf, k, 0)
            if (reach & goal_region).any():
                return Arrival(t0 + k * dt, k, int(reach.sum()))
            reach = _grown(reach) & clear_at(t0 + (k + 1) * dt)
        return Arrival(math.inf, steps, int(reach.sum()))


def _grown(reach: np.ndarray) -> np.ndarray:
    """``reach`` dilated by one step of travel, computed on the window around it only (the set starts as a cell)."""
    rows, cols = np.flatnonzero(reach.any(axis=1)), np.flatnonzero(reach.any(axis=0))
    r0, r1 = max(rows[0] - STEP_CELLS, 0), min(rows[-1] + STEP_CELLS + 1, reach.shape[0])
    c0, c1 = max(cols[0] - STEP_CELLS, 0), min(cols[-1] + STEP_CELLS + 1, reach.shape[1])
    out = np.zeros_like(reach)
    out[r0:r1, c0:c1] = ndimage.binary_dilation(reach[r0:r1, c0:c1], structure=_DISC)
    return out
