"""Costmap2D: a uint8 cost grid with costmap_2d's exact coordinate conventions (REFERENCE §0.2).

The grid is stored as ``costmap[my, mx]`` (row = y), which is the same memory
layout as costmap_2d's ``index = my * size_x + mx`` and as nav_msgs/OccupancyGrid.
"""

from __future__ import annotations

import math

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
        """Cell containing (wx, wy), or None when it lies off the grid."""
        if wx < self.origin_x or wy < self.origin_y:
            return None
        mx = int((wx - self.origin_x) / self.resolution)
        my = int((wy - self.origin_y) / self.resolution)
        if mx < self.size_x and my < self.size_y:
            return mx, my
        return None

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
        self.__init__(size_x, size_y, resolution, origin_x, origin_y, self.default_value)
