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

The same wavefront, kept step by step, also gives a path in space and time (``SpaceTimeSearch.path``): the reachable
place at the horizon that leaves the least way to go, and how to be there, traced back through the kept steps. A
receding-horizon controller follows it (mppi/guide.py): it chooses the gap and the moment to go through it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.planning.space_time_kernels import grown_within, mark_discs

#: cells the robot's centre moves per time step (the dilation's radius)
STEP_CELLS = 2
_DISC = (np.hypot(*np.mgrid[-STEP_CELLS:STEP_CELLS + 1, -STEP_CELLS:STEP_CELLS + 1]) <= STEP_CELLS + 1e-9)
#: the same disc as (row, col) offsets
_OFFSETS = np.ascontiguousarray(np.argwhere(_DISC) - STEP_CELLS)


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
        centres = np.ascontiguousarray(discs.centres, dtype=float).reshape(-1, 2)
        reach = np.ascontiguousarray(discs.radii + grow, dtype=float).reshape(-1)
        mark_discs(out, self.origin[0], self.origin[1], self.resolution, centres, reach)
        return out

    def earliest_arrival(self, start: tuple[float, float], goal: tuple[float, float], goal_radius: float,
                         speed: float, discs_at: Callable[[float], MovingDiscs], t0: float, horizon_s: float,
                         clearance: float = 0.0) -> Arrival:
        """From ``start`` at time ``t0``, the first time within ``horizon_s`` the robot's centre can be within
        ``goal_radius`` of ``goal`` at ``speed`` m/s, staying ``clearance`` m beyond every moving disc
        (``discs_at(t)``, radii being each obstacle's plus the robot's)."""
        dt = self.step_s(_checked_speed(speed))
        goal_region = self.free & (np.hypot(self._x - goal[0], self._y - goal[1]) <= goal_radius)
        steps = int(math.ceil(horizon_s / dt))
        k, reach = 0, np.zeros(self.free.shape, dtype=bool)
        for k, reach in enumerate(self._wavefront(start, speed, discs_at, t0, steps, clearance, False)):
            if not reach.any():
                return Arrival(math.inf, k, 0)
            if (reach & goal_region).any():
                return Arrival(t0 + k * dt, k, int(reach.sum()))
        return Arrival(math.inf, k, int(reach.sum()))

    def path(self, start: tuple[float, float], cost_to_go: Callable[[np.ndarray], np.ndarray], speed: float,
             discs_at: Callable[[float], MovingDiscs], t0: float, horizon_s: float,
             clearance: float = 0.0) -> SpaceTimePath | None:
        """From ``start`` at ``t0``: the cell reachable at the horizon (or, if the robot is caught before it, at the
        last step anything is reachable) with the least ``cost_to_go`` (of points (n, 2), metres; of equals, the
        one reached first), and the way there, one point per step. Traced back, each step stays in its cell when that was reachable a step earlier, else it
        moves to the neighbour first reached earliest: the path goes as early as it can and waits late. The start
        cell counts as free at ``t0`` (the robot is there, whatever is near it). None if ``start`` is off the grid
        or nothing is reachable after it."""
        dt = self.step_s(_checked_speed(speed))
        steps = int(math.ceil(horizon_s / dt))
        kept = []
        for reach in self._wavefront(start, speed, discs_at, t0, steps, clearance, True):
            if not reach.any():
                break
            kept.append(reach)
        if len(kept) < 2:
            return None
        first = np.full(self.free.shape, len(kept))
        for k in range(len(kept) - 1, -1, -1):
            first[kept[k]] = k
        rows, cols = np.nonzero(kept[-1])
        best = np.lexsort((first[rows, cols], cost_to_go(np.column_stack([self._x[rows, cols], self._y[rows, cols]]))))
        cells = [(int(rows[best[0]]), int(cols[best[0]]))]
        for k in range(len(kept) - 1, 0, -1):
            row, col = cells[-1]
            rows, cols = row + _OFFSETS[:, 0], col + _OFFSETS[:, 1]
            inside = (rows >= 0) & (rows < self.free.shape[0]) & (cols >= 0) & (cols < self.free.shape[1])
            rows, cols = rows[inside], cols[inside]
            rows, cols = rows[kept[k - 1][rows, cols]], cols[kept[k - 1][rows, cols]]
            away = np.hypot(rows - row, cols - col)
            order = np.lexsort((away, first[rows, cols], away > 0))
            cells.append((int(rows[order[0]]), int(cols[order[0]])))
        rows, cols = np.array(cells[::-1]).T
        xy = np.column_stack([self._x[rows, cols], self._y[rows, cols]])
        xy[0] = start
        return SpaceTimePath(t0 + dt * np.arange(len(xy)), xy, len(kept) == steps + 1)

    def _wavefront(self, start, speed, discs_at, t0, steps, clearance, start_free):
        """The reachable sets at t0, t0 + dt, ... t0 + steps dt (stops after an empty one)."""
        dt = self.step_s(speed)
        start_cell = self.cell(*start)
        reach = np.zeros(self.free.shape, dtype=bool)
        if start_cell is None:
            yield reach
            return

        def clear_at(t: float) -> np.ndarray:
            discs = discs_at(t)
            return self.free & ~self.blocked(discs, clearance + 0.5 * dt * (discs.speeds + speed))

        reach[start_cell] = True if start_free else clear_at(t0)[start_cell]
        for k in range(steps + 1):
            yield reach
            if not reach.any() or k == steps:
                return
            reach = grown_within(reach, clear_at(t0 + (k + 1) * dt), _OFFSETS)


@dataclass(frozen=True)
class SpaceTimePath:
    """Where the robot's centre should be when: ``times`` (N,) from the search's t0 one step apart, ``xy`` (N, 2);
    ``full``: it lasts the whole horizon (False: the robot is caught before its end, wherever it goes)."""
    times: np.ndarray
    xy: np.ndarray
    full: bool

    def at(self, t) -> np.ndarray:
        """The point(s) at time(s) ``t``, held at the ends."""
        t = np.asarray(t, dtype=float)
        return np.stack([np.interp(t, self.times, self.xy[:, 0]), np.interp(t, self.times, self.xy[:, 1])], axis=-1)


def _checked_speed(speed: float) -> float:
    if not speed > 0:
        raise ValueError(f"speed must be > 0, got {speed}")
    return speed
