"""The compiled inner loop of the space-time search (space_time.py): marking the cells two dozen discs cover, once
per time step. In numpy each disc costs a handful of small temporaries, which over sixty steps was half a replan."""

from __future__ import annotations

import math

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
