"""Costmap2D: a uint8 cost grid with costmap_2d's exact coordinate conventions (docs/reference.md §0.2).

The grid is stored as ``costmap[my, mx]`` (row = y), which is the same memory
layout as costmap_2d's ``index = my * size_x + mx`` and as nav_msgs/OccupancyGrid.
"""

from __future__ import annotations

import math

import numba
import numpy as np


class Costmap2D:
    def __init__(self, size_x: int, size_y: int, resolution: float,
                 origin_x: float, origin_y: float, default_value: int = 0):
        if size_x < 0 or size_y < 0:
            raise ValueError(f"costmap size must be non-negative, got {size_x} x {size_y}")
        if not resolution > 0:
            raise ValueError(f"costmap resolution must be positive, got {resolution}")
        self.size_x = int(size_x)
        self.size_y = int(size_y)
        self.resolution = float(resolution)
        self.origin_x = float(origin_x)
        self.origin_y = float(origin_y)
        self.default_value = int(default_value)
        self.costmap = np.full((self.size_y, self.size_x), self.default_value, dtype=np.uint8)

    # -- geometry -------------------------------------------------------------
    @property
    def size_in_meters_x(self) -> float:
        """Half a cell less than size_x * resolution, as costmap_2d's getSizeInMetersX."""
        return (self.size_x - 1 + 0.5) * self.resolution

    @property
    def size_in_meters_y(self) -> float:
        return (self.size_y - 1 + 0.5) * self.resolution

    def cell_distance(self, world_dist: float) -> int:
        return max(0, int(math.ceil(world_dist / self.resolution)))

    def map_to_world(self, mx: float, my: float) -> tuple[float, float]:
        """World coordinates of the centre of cell (mx, my)."""
        return (self.origin_x + (mx + 0.5) * self.resolution,
                self.origin_y + (my + 0.5) * self.resolution)

    def world_to_map(self, wx: float, wy: float) -> tuple[int, int] | None:
        """Cell containing (wx, wy), or None when it lies off the grid (or is not a finite number)."""
        fx = (wx - self.origin_x) / self.resolution
        fy = (wy - self.origin_y) / self.resolution
        if not (0 <= fx < self.size_x and 0 <= fy < self.size_y):   # compared as floats: 1e308 and NaN too
            return None
        return int(fx), int(fy)

    def world_to_map_no_bounds(self, wx: float, wy: float) -> tuple[int, int]:
        return (int((wx - self.origin_x) / self.resolution),
                int((wy - self.origin_y) / self.resolution))

    def world_to_map_enforce_bounds(self, wx: float, wy: float) -> tuple[int, int]:
        """Clamp to the grid; raw doubles are compared first so that +-1e30 bounds work."""
        def clamp(w: float, origin: float, size: int) -> int:
            if w < origin:
                return 0
            if w >= self.resolution * size + origin:
                return size - 1
            return int((w - origin) / self.resolution)
        return (clamp(wx, self.origin_x, self.size_x), clamp(wy, self.origin_y, self.size_y))

    def world_to_map_array(self, wx: np.ndarray, wy: np.ndarray):
        """Vectorised world_to_map: returns (mx, my, valid) with truncation toward zero."""
        fx = (np.asarray(wx, dtype=float) - self.origin_x) / self.resolution
        fy = (np.asarray(wy, dtype=float) - self.origin_y) / self.resolution
        mx = np.trunc(fx).astype(np.int64)
        my = np.trunc(fy).astype(np.int64)
        valid = (fx >= 0) & (fy >= 0) & (mx < self.size_x) & (my < self.size_y)
        return mx, my, valid

    # -- access ---------------------------------------------------------------
    def get_cost(self, mx: int, my: int) -> int:
        return int(self.costmap[my, mx])

    def set_cost(self, mx: int, my: int, cost: int) -> None:
        self.costmap[my, mx] = cost

    def reset_map(self, x0: int, y0: int, xn: int, yn: int) -> None:
        """Set the window [x0, xn) x [y0, yn) to the default value."""
        self.costmap[y0:yn, x0:xn] = self.default_value

    def resize_map(self, size_x: int, size_y: int, resolution: float,
                   origin_x: float, origin_y: float) -> None:
        Costmap2D.__init__(self, size_x, size_y, resolution, origin_x, origin_y, self.default_value)

    def reset_maps(self) -> None:
        self.costmap.fill(self.default_value)

    # -- windows ----------------------------------------------------------------
    def window(self, x0: int, y0: int, xn: int, yn: int) -> np.ndarray:
        """Copy of the cells [x0, xn) x [y0, yn), row-major as in OccupancyGridUpdate."""
        return self.costmap[y0:yn, x0:xn].copy()

    def copy(self) -> "Costmap2D":
        """An independent grid with the same geometry and costs."""
        other = Costmap2D(0, 0, self.resolution, self.origin_x, self.origin_y, self.default_value)
        other.size_x, other.size_y = self.size_x, self.size_y
        other.costmap = self.costmap.copy()
        return other

    # -- rolling window ---------------------------------------------------------
    def update_origin(self, new_origin_x: float, new_origin_y: float) -> None:
        """Move the origin by whole cells (truncated toward zero), keeping the overlapping block.

        Newly exposed cells get the default value; the origin stays grid-aligned with the old one.
        """
        cell_ox = int((new_origin_x - self.origin_x) / self.resolution)
        cell_oy = int((new_origin_y - self.origin_y) / self.resolution)
        if cell_ox == 0 and cell_oy == 0:
            return
        sx, sy = self.size_x, self.size_y
        lx, ly = min(max(cell_ox, 0), sx), min(max(cell_oy, 0), sy)
        ux, uy = min(max(cell_ox + sx, 0), sx), min(max(cell_oy + sy, 0), sy)
        kept = self.costmap[ly:uy, lx:ux].copy()
        self.costmap.fill(self.default_value)
        self.origin_x += cell_ox * self.resolution
        self.origin_y += cell_oy * self.resolution
        tx, ty = lx - cell_ox, ly - cell_oy
        self.costmap[ty:ty + kept.shape[0], tx:tx + kept.shape[1]] = kept

    # -- raytracing -------------------------------------------------------------
    def raytrace_cells(self, x0, y0, x1, y1, max_length: float = math.inf):
        """Cells visited by costmap_2d's Bresenham raytrace from (x0, y0) to each (x1, y1).

        Vectorised over rays: x0/y0 and x1/y1 broadcast against each other. Each ray takes
        ``min(int(scale * major), major)`` steps (scale shortens rays longer than max_length
        cells) and then visits the cell it stopped on once more, so the start cell and the final
        cell are both included. Returns (mx, my) int64 arrays, rays concatenated in order, each
        ray's cells from start to end.
        """
        x0, y0, x1, y1 = np.broadcast_arrays(*(np.asarray(v, dtype=np.int64) for v in (x0, y0, x1, y1)))
        return _raytrace(x0.ravel(), y0.ravel(), x1.ravel(), y1.ravel(), float(max_length))

    def raytrace_line(self, x0: int, y0: int, x1: int, y1: int, max_length: float = math.inf):
        """Cells of one raytrace as a list of (mx, my), start to end."""
        mx, my = self.raytrace_cells(x0, y0, x1, y1, max_length)
        return list(zip(mx.tolist(), my.tolist()))

    # -- polygons ---------------------------------------------------------------
    def polygon_outline_cells(self, polygon_cells) -> tuple[np.ndarray, np.ndarray]:
        """Raytraced edges of a closed polygon given in map cells (N x 2)."""
        p = np.asarray(polygon_cells, dtype=np.int64).reshape(-1, 2)
        q = np.roll(p, -1, axis=0)
        return self.raytrace_cells(p[:, 0], p[:, 1], q[:, 0], q[:, 1])

    def convex_fill_cells(self, polygon_cells) -> tuple[np.ndarray, np.ndarray]:
        """Cells filling a convex polygon: every column of the outline, from its lowest to its highest cell."""
        p = np.asarray(polygon_cells, dtype=np.int64).reshape(-1, 2)
        if len(p) < 3:
            return np.empty(0, np.int64), np.empty(0, np.int64)
        ox, oy = self.polygon_outline_cells(p)
        x_lo = int(ox.min())
        width = int(ox.max()) - x_lo + 1
        low = np.full(width, np.iinfo(np.int64).max)
        high = np.full(width, np.iinfo(np.int64).min)
        np.minimum.at(low, ox - x_lo, oy)
        np.maximum.at(high, ox - x_lo, oy)
        counts = high - low + 1
        col = np.repeat(np.arange(width), counts)
        first = np.cumsum(counts) - counts
        fy = low[col] + np.arange(int(counts.sum())) - first[col]
        return col + x_lo, fy

    def cells_within_circles(self, wx, wy, radius) -> tuple[np.ndarray, np.ndarray]:
        """(mx, my) of every grid cell whose centre lies within one of the circles (world x, y, radius);
        a cell in several circles comes several times."""
        wx, wy, radius = (np.asarray(v, dtype=float).reshape(-1) for v in (wx, wy, radius))
        if not len(radius) or not self.size_x or not self.size_y:
            return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
        res = self.resolution
        reach = int(math.ceil(radius.max() / res))
        span = np.arange(-reach, reach + 1)
        cx = np.floor((wx - self.origin_x) / res).astype(np.int64)[:, None, None] + span[None, None, :]
        cy = np.floor((wy - self.origin_y) / res).astype(np.int64)[:, None, None] + span[None, :, None]
        dx = self.origin_x + (cx + 0.5) * res - wx[:, None, None]
        dy = self.origin_y + (cy + 0.5) * res - wy[:, None, None]
        inside = (dx * dx + dy * dy <= (radius ** 2)[:, None, None]) & (cx >= 0) & (cx < self.size_x) & \
            (cy >= 0) & (cy < self.size_y)
        return np.broadcast_to(cx, inside.shape)[inside], np.broadcast_to(cy, inside.shape)[inside]

    def set_convex_polygon_cost(self, polygon_world, cost_value: int) -> bool:
        """Fill a convex polygon given in world coordinates.

        Does nothing and returns False if any vertex is off the map (footprint clearing near the
        edge of a rolling window is then skipped, as in costmap_2d).
        """
        p = np.asarray(polygon_world, dtype=float).reshape(-1, 2)
        mx, my, valid = self.world_to_map_array(p[:, 0], p[:, 1])
        if not valid.all():
            return False
        fx, fy = self.convex_fill_cells(np.stack([mx, my], axis=1))
        self.costmap[fy, fx] = cost_value
        return True


@numba.njit(cache=True, nogil=True)
def _ray_steps(dx, dy, max_length):
    major = max(abs(dx), abs(dy))
    dist = math.hypot(dx, dy)
    scale = 1.0 if dist == 0.0 else min(1.0, max_length / dist)
    return min(int(scale * major), major)


@numba.njit(cache=True, nogil=True)
def _raytrace(x0, y0, x1, y1, max_length):
    n = len(x0)
    total = 0
    for r in range(n):
        total += _ray_steps(x1[r] - x0[r], y1[r] - y0[r], max_length) + 1
    mx = np.empty(total, dtype=np.int64)
    my = np.empty(total, dtype=np.int64)
    k = 0
    for r in range(n):
        dx, dy = x1[r] - x0[r], y1[r] - y0[r]
        adx, ady = abs(dx), abs(dy)
        sx = 1 if dx > 0 else -1
        sy = 1 if dy > 0 else -1
        x_major = adx >= ady
        major, minor = (adx, ady) if x_major else (ady, adx)
        error = major // 2
        x, y = x0[r], y0[r]
        for _ in range(_ray_steps(dx, dy, max_length)):
            mx[k], my[k] = x, y
            k += 1
            error += minor
            step_minor = error >= major
            if step_minor:
                error -= major
            if x_major:
                x += sx
                y += sy if step_minor else 0
            else:
                y += sy
                x += sx if step_minor else 0
        mx[k], my[k] = x, y
        k += 1
    return mx, my
