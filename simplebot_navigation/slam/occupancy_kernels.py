"""The compiled ray casting of the occupancy grid (occupancy.py): a 1366-beam scan walks some 150 000 cells, one
Python loop step each would take a second.

Each call is one observation of the cells it touches: a cell changes at most once per call, and a cell that is
some beam's return is marked, never cleared, by the same scan (a beam grazing a wall on its way to the next
return must not erase the wall a neighbouring beam just hit). Integer cells only, so the result is the same on
every machine."""

from __future__ import annotations

from numba import njit
import numpy as np

#: the per-call scratch marks of a cell
_UNSEEN, _CROSSED, _RETURN = 0, 1, 2


@njit(cache=True, nogil=True, inline="always")
def _cross(scratch, x0, y0, x1, y1, include_end):
    """Bresenham's line from cell (x0, y0) to (x1, y1), scratch-relative: mark the cells as crossed (the end
    cell only when ``include_end``) unless they are a return."""
    dx, dy = abs(x1 - x0), -abs(y1 - y0)
    sx = 1 if x0 < x1 else -1
    sy = 1 if y0 < y1 else -1
    error, x, y = dx + dy, x0, y0
    while x != x1 or y != y1:
        if scratch[y, x] == _UNSEEN:
            scratch[y, x] = _CROSSED
        twice = 2 * error
        if twice >= dy:
            error += dy
            x += sx
        if twice <= dx:
            error += dx
            y += sy
    if include_end and scratch[y, x] == _UNSEEN:
        scratch[y, x] = _CROSSED


@njit(cache=True, nogil=True)
def integrate_beams(log_odds, starts, ends, hits, hit_update, miss_update, low, high):
    """Add ``miss_update`` to the log-odds of every cell a beam crosses and ``hit_update`` to every return's end
    cell, each cell once, clamped to [low, high]. ``starts`` and ``ends`` (N, 2) are (col, row) cells inside
    ``log_odds`` (rows = y); a miss beam's end cell counts as crossed."""
    n = starts.shape[0]
    if n == 0:
        return
    col0, row0 = min(starts[:, 0].min(), ends[:, 0].min()), min(starts[:, 1].min(), ends[:, 1].min())
    col1, row1 = max(starts[:, 0].max(), ends[:, 0].max()), max(starts[:, 1].max(), ends[:, 1].max())
    scratch = np.zeros((row1 - row0 + 1, col1 - col0 + 1), dtype=np.uint8)
    for b in range(n):
        if hits[b]:
            scratch[ends[b, 1] - row0, ends[b, 0] - col0] = _RETURN
    for b in range(n):
        _cross(scratch, starts[b, 0] - col0, starts[b, 1] - row0, ends[b, 0] - col0, ends[b, 1] - row0, not hits[b])
    for r in range(scratch.shape[0]):
        for c in range(scratch.shape[1]):
            mark = scratch[r, c]
            if mark != _UNSEEN:
                value = log_odds[row0 + r, col0 + c] + (hit_update if mark == _RETURN else miss_update)
                log_odds[row0 + r, col0 + c] = min(max(value, low), high)
