"""The compiled inner loops of the space-time search (space_time.py), once per time step: marking the cells two
dozen discs cover, and growing the reachable set by a step of travel. In numpy each disc costs a handful of small
temporaries, and the growth a dilation plus a mask; over sixty steps each was about half a replan."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def mark_discs(out, origin_x, origin_y, resolution, centres, reach):
    """Set ``out[row, col]`` (rows = y) for every cell whose centre lies within ``reach[i]`` of ``centres[i]``."""
    rows, cols = out.shape
    for i in range(centres.shape[0]):
        cx, cy, r = centres[i, 0], centres[i, 1], reach[i]
        if not (math.isfinite(cx) and math.isfinite(cy) and math.isfinite(r)) or r < 0.0:
            continue
        r0 = max(int(math.floor((cy - r - origin_y) / resolution)), 0)
        r1 = min(int(math.ceil((cy + r - origin_y) / resolution)) + 1, rows)
        c0 = max(int(math.floor((cx - r - origin_x) / resolution)), 0)
        c1 = min(int(math.ceil((cx + r - origin_x) / resolution)) + 1, cols)
        for row in range(r0, r1):
            dy = origin_y + (row + 0.5) * resolution - cy
            for col in range(c0, c1):
                dx = origin_x + (col + 0.5) * resolution - cx
                if dx * dx + dy * dy <= r * r:
                    out[row, col] = True


@njit(cache=True, nogil=True)
def grown_within(reach, allowed, offsets):
    """The cells of ``allowed`` that a cell of ``reach`` reaches by one of ``offsets`` ((n, 2) row, col; (0, 0)
    among them): the reachable set one step later. Only the box round ``reach`` is looked at."""
    rows, cols = reach.shape
    out = np.zeros_like(reach)
    r0, r1, c0, c1 = rows, -1, cols, -1
    for row in range(rows):
        for col in range(cols):
            if reach[row, col]:
                r0, r1, c0, c1 = min(r0, row), max(r1, row), min(c0, col), max(c1, col)
    if r1 < 0:
        return out
    pad = 0
    for i in range(offsets.shape[0]):
        pad = max(pad, abs(offsets[i, 0]), abs(offsets[i, 1]))
    for row in range(max(r0 - pad, 0), min(r1 + pad + 1, rows)):
        for col in range(max(c0 - pad, 0), min(c1 + pad + 1, cols)):
            if not allowed[row, col]:
                continue
            for i in range(offsets.shape[0]):
                r, c = row - offsets[i, 0], col - offsets[i, 1]
                if 0 <= r < rows and 0 <= c < cols and reach[r, c]:
                    out[row, col] = True
                    break
    return out
