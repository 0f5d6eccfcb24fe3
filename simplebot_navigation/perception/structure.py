"""StructureMap: where lidar returns keep landing, in the tracking frame (docs/reference.md §6).

Seen from a robot that moves or turns, a wall breaks into small clusters (the adaptive breakpoint cuts a surface
seen at a grazing angle) whose centres slide along it: a door's jambs read as people walking. What is static
is hit in scan after scan at the same place; a walking person covers a 0.1 m cell for a fraction of a second. Each
cell keeps an exponential average of "a return landed here" over ``time_constant``; a return on a cell (or a
neighbour of it) whose average is at least STRUCTURE_SCORE lies on structure. A cluster that lies mostly on
structure is not tracked, however small it is.

The cells form a square window around the sensors, moved along with them in whole cells: a dense array, so an
update costs a few array operations however much the robot has seen.
"""

from __future__ import annotations

import math

import numpy as np

#: cell side of the map, metres
CELL = 0.1
#: cells along a side of the window: 14.4 m, the lidars' 5.6 m range around the robot with room to drive
SIDE = 144
#: the window moves once its centre is this many cells from the sensors
RECENTRE_CELLS = 5
#: average at or above which a cell is structure: hit in every scan for about 0.7 time constants, or in half of
#: the scans for long
STRUCTURE_SCORE = 0.5
#: the longest gap between two updates that still counts as scan to scan (a longer one weighs like this)
MAX_STEP_S = 0.5
_OFFSETS = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]


class StructureMap:
    """``update(points, stamp, centre)`` per tracker update: points (N, 2) in the tracking frame, NaN rows for beams
    without a return; centre: where the sensors are."""

    def __init__(self, time_constant: float):
        self.time_constant = float(time_constant)
        self.clear()

    def clear(self) -> None:
        self.score = np.zeros((SIDE + 2, SIDE + 2))     # a border of never-hit cells around the window
        self.corner = np.zeros(2)                      # the window's first cell's corner (x, y), metres
        self.stamp: float | None = None

    def update(self, points: np.ndarray, stamp: float, centre: np.ndarray, learn: np.ndarray | None = None
               ) -> np.ndarray:
        """(N,) whether each point lies on (or next to) a cell that returns had kept hitting before this update;
        then every cell decays and the cells these points hit (those ``learn`` marks, default all) gain one step's
        weight."""
        found = np.zeros(len(points), dtype=bool)
        if self.time_constant <= 0 or not np.isfinite(centre).all() or abs(centre).max() > 1e9:
            return found
        elapsed = 0.1 if self.stamp is None else max(stamp - self.stamp, 0.0)
        decay = 0.0 if self.stamp is None else math.exp(-elapsed / self.time_constant)
        self._follow(centre)
        with np.errstate(invalid="ignore"):
            cell = np.floor((points - self.corner) / CELL)                # NaN rows stay NaN
            inside = (cell[:, 0] >= 0) & (cell[:, 0] < SIDE) & (cell[:, 1] >= 0) & (cell[:, 1] < SIDE)
        row, col = cell[inside, 1].astype(np.int64) + 1, cell[inside, 0].astype(np.int64) + 1
        self.score *= decay
        best = np.zeros(len(row))
        for dy, dx in _OFFSETS:
            best = np.maximum(best, self.score[row + dy, col + dx])
        found[inside] = best >= STRUCTURE_SCORE
        if learn is not None:
            kept = np.asarray(learn, dtype=bool)[inside]
            row, col = row[kept], col[kept]
        self.score[row, col] += 1.0 - math.exp(-min(elapsed, MAX_STEP_S) / self.time_constant)   # once per cell
        self.stamp = float(stamp)
        return found

    def _follow(self, centre: np.ndarray) -> None:
        """Move the window by whole cells so that it stays centred on the sensors; cells it leaves are forgotten."""
        wanted = (np.floor(centre / CELL) - SIDE // 2) * CELL
        shift = np.rint((wanted - self.corner) / CELL).astype(np.int64)
        if self.stamp is not None and np.abs(shift).max() <= RECENTRE_CELLS:
            return
        moved = np.zeros_like(self.score)
        sx, sy = int(shift[0]), int(shift[1])
        if self.stamp is not None and abs(sx) < SIDE and abs(sy) < SIDE:
            inner, kept = self.score[1:-1, 1:-1], moved[1:-1, 1:-1]
            kept[max(-sy, 0):SIDE - max(sy, 0), max(-sx, 0):SIDE - max(sx, 0)] = \
                inner[max(sy, 0):SIDE - max(-sy, 0), max(sx, 0):SIDE - max(-sx, 0)]
        self.score, self.corner = moved, wanted


class StaticCells:
    """What a map knows to be static, for ObstacleTracker.set_static_cells: `occupied` (rows y, columns x) cells
    of `resolution` metres, cell (0, 0)'s corner at `origin` (x, y) in the tracking frame. A point on an occupied
    cell or next to one (a cell's slack for the map's own error) is static; outside the grid nothing is."""

    def __init__(self, occupied: np.ndarray, resolution: float, origin):
        occupied = np.asarray(occupied, dtype=bool)
        if occupied.ndim != 2 or not (np.isfinite(resolution) and resolution > 0):
            raise ValueError(f"StaticCells: a 2-D grid and a positive resolution are needed, got shape "
                             f"{occupied.shape} and resolution {resolution!r}")
        grown = np.pad(occupied, 1)
        self.cells = np.zeros_like(grown)
        for dy, dx in _OFFSETS:
            self.cells |= np.roll(grown, (dy, dx), axis=(0, 1))
        self.resolution = float(resolution)
        self.origin = np.asarray(origin, dtype=float) - self.resolution    # the padding's corner

    def __call__(self, points: np.ndarray) -> np.ndarray:
        cell = np.floor((np.asarray(points, dtype=float) - self.origin) / self.resolution)
        rows, cols = self.cells.shape
        with np.errstate(invalid="ignore"):
            inside = (cell[:, 0] >= 0) & (cell[:, 0] < cols) & (cell[:, 1] >= 0) & (cell[:, 1] < rows)
        out = np.zeros(len(cell), dtype=bool)
        out[inside] = self.cells[cell[inside, 1].astype(np.int64), cell[inside, 0].astype(np.int64)]
        return out
