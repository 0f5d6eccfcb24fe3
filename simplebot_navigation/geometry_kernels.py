"""Compiled geometry the kernels of several packages share (teb/footprint_kernels, safety/collision_kernels).

A kernel that calls one of these inlines it, so each package's kernel_cache fingerprint includes this file.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, nogil=True)
def inside_polygon(qx, qy, vertices):
    """Even-odd rule: the point (qx, qy) against the closed polygon ``vertices`` (V, 2)."""
    inside = False
    nv = vertices.shape[0]
    for i in range(nv):
        j = i - 1 if i > 0 else nv - 1
        xi, yi, xj, yj = vertices[i, 0], vertices[i, 1], vertices[j, 0], vertices[j, 1]
        if (yi > qy) != (yj > qy):
            if qx < (xj - xi) * (qy - yi) / (yj - yi) + xi:
                inside = not inside
    return inside
