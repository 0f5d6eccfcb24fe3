"""StructureMap: where lidar returns keep landing, in the tracking frame (docs/reference.md §6).

Seen from a robot that moves or turns, a wall breaks into small clusters (the adaptive breakpoint cuts a surface
seen at a grazing angle) whose centres slide along it: a door's jambs read as people walking. What is static
is hit in scan after scan at the same place; a walking person covers a 0.1 m cell for a fraction of a second. Each
cell keeps an exponential average of "a return landed here" over ``time_constant``; a return on a cell (or a
neighbour of it) whose average is at least STRUCTURE_SCORE lies on structure. A cluster that lies mostly on
structure is not tracked, however small it is.
"""

from __future__ import annotations

import math

import numpy as np

#: cell side of the map, metres
CELL = 0.1
#: average at or above which a cell is structure: hit in every scan for about 0.7 time constants, or in half of
#: the scans for long
STRUCTURE_SCORE = 0.5
#: cells whose average fell below this are forgotten (about 4 time constants after their last return)
FORGET_SCORE = 0.02
#: the longest gap between two updates that still counts as scan to scan (a longer one weighs like this)
MAX_STEP_S = 0.5
#: cell indices are clipped to +-this (100 km at 0.1 m), so any coordinate gives a key
INDEX_LIMIT = 1 << 20
_SPAN = 2 * INDEX_LIMIT + 1
_NEIGHBOURS = np.array([dx * _SPAN + dy for dx in (-1, 0, 1) for dy in (-1, 0, 1)], dtype=np.int64)


class StructureMap:
    """``structure(points, stamp)`` before ``add(points, stamp)``, per update; points (N, 2) in the tracking frame,
    NaN rows for beams without a return."""

    def __init__(self, time_constant: float):
        self.time_constant = float(time_constant)
        self.clear()

    def clear(self) -> None:
        self.keys = np.empty(0, dtype=np.int64)      # sorted
        self.score = np.empty(0)                     # as of self.stamp
        self.stamp: float | None = None

    def structure(self, points: np.ndarray, stamp: float) -> np.ndarray:
        """(N,) whether each point lies on (or next to) a cell that returns have kept hitting."""
        found = np.zeros(len(points), dtype=bool)
        if not len(self.keys) or self.time_constant <= 0:
            return found
        finite = np.isfinite(points).all(axis=1)
        keys = _keys(points[finite])
        decay = math.exp(-max(stamp - self.stamp, 0.0) / self.time_constant)
        best = np.zeros(len(keys))
        for offset in _NEIGHBOURS:
            candidate = keys + offset
            index = np.minimum(np.searchsorted(self.keys, candidate), len(self.keys) - 1)
            best = np.maximum(best, np.where(self.keys[index] == candidate, self.score[index], 0.0))
        found[finite] = best * decay >= STRUCTURE_SCORE
        return found

    def add(self, points: np.ndarray, stamp: float) -> None:
        """The returns of the update at `stamp`: every cell decays, the cells hit gain one step's weight."""
        if self.time_constant <= 0:
            return
        step = 0.1 if self.stamp is None else min(max(stamp - self.stamp, 0.0), MAX_STEP_S)
        decay = 1.0 if self.stamp is None else math.exp(-max(stamp - self.stamp, 0.0) / self.time_constant)
        hit = np.unique(_keys(points[np.isfinite(points).all(axis=1)]))
        keys = np.union1d(self.keys, hit)
        score = np.zeros(len(keys))
        score[np.searchsorted(keys, self.keys)] = self.score * decay
        score[np.searchsorted(keys, hit)] += 1.0 - math.exp(-step / self.time_constant)
        keep = score >= FORGET_SCORE
        self.keys, self.score, self.stamp = keys[keep], score[keep], float(stamp)


def _keys(points: np.ndarray) -> np.ndarray:
    index = np.clip(np.floor(points / CELL), -INDEX_LIMIT, INDEX_LIMIT).astype(np.int64)
    return index[:, 0] * _SPAN + index[:, 1]
