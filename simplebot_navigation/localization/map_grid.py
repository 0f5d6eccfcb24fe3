"""The map as amcl sees it: free, occupied and unknown cells, and the distance fields its models read.

The grid comes as plain values in nav_msgs/OccupancyGrid order: an int8 array [height, width] whose row 0 is the
bottom row (at the origin's y), -1 unknown, 0..100 occupancy; the resolution; and the origin (x, y, yaw) of cell
(0, 0)'s outer corner. As amcl's convertMap: exactly 0 is free, exactly 100 occupied, anything else unknown.

Cell indices are floor((x - origin) / resolution) in the grid frame. amcl rounds instead (MAP_GXWX adds half a
cell), which shifts its map half a cell; and amcl ignores the origin's yaw, which is honoured here.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

FREE, OCCUPIED = 0, 100


class AmclMap:
    """An occupancy grid with the grid-frame transform and the per-cell fields of the laser models."""

    def __init__(self, data, resolution: float, origin=(0.0, 0.0, 0.0)):
        data = np.asarray(data)
        if data.ndim != 2 or data.size == 0:
            raise ValueError(f"map data: expected a non-empty [height, width] array, got shape {data.shape}")
        if not np.issubdtype(data.dtype, np.integer) or data.min() < -128 or data.max() > 127:
            raise ValueError("map data: expected int8 occupancy values (-1 unknown, 0..100)")
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"map resolution: must be a positive number, got {resolution!r}")
        origin = tuple(float(v) for v in origin)
        if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
            raise ValueError(f"map origin: expected finite (x, y, yaw), got {origin!r}")
        self.height, self.width = data.shape
        self.resolution = float(resolution)
        self.origin = origin
        self.free = data == FREE
        self.occupied = data == OCCUPIED
        if not self.free.any():
            raise ValueError("map data: no free cell, nowhere for the robot to be")
        self._cos, self._sin = math.cos(origin[2]), math.sin(origin[2])

    def to_grid(self, poses: np.ndarray) -> np.ndarray:
        """(N, 3) poses in the global frame -> the grid frame in cell units (x, y) and radians (yaw)."""
        dx, dy = poses[:, 0] - self.origin[0], poses[:, 1] - self.origin[1]
        out = np.empty_like(poses, dtype=np.float64)
        out[:, 0] = (self._cos * dx + self._sin * dy) / self.resolution
        out[:, 1] = (-self._sin * dx + self._cos * dy) / self.resolution
        out[:, 2] = poses[:, 2] - self.origin[2]
        return out

    def is_free(self, x: float, y: float) -> bool:
        """Whether the point (global frame) lies in a free cell of the map."""
        col, row = np.floor(self.to_grid(np.array([[x, y, 0.0]]))[0, :2])
        return bool(0 <= col < self.width and 0 <= row < self.height and self.free[int(row), int(col)])

    def cell_centres(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """(K, 2) global-frame centres of the given cells."""
        gx, gy = (cols + 0.5) * self.resolution, (rows + 0.5) * self.resolution
        return np.column_stack((self.origin[0] + self._cos * gx - self._sin * gy,
                                self.origin[1] + self._sin * gx + self._cos * gy))

    def free_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of every free cell, where global localization and recovery place particles."""
        return np.nonzero(self.free)

    def obstacle_distance(self, max_dist: float) -> np.ndarray:
        """Distance (m) from each cell centre to the nearest occupied cell centre, capped at ``max_dist``
        (amcl's occ_dist; unknown cells are no obstacles here)."""
        if not self.occupied.any():
            return np.full((self.height, self.width), max_dist)
        distance = ndimage.distance_transform_edt(~self.occupied) * self.resolution
        return np.minimum(distance, max_dist)

    def blocked(self) -> np.ndarray:
        """uint8 per cell: 1 where a ray stops (occupied or unknown, as amcl's map_calc_range)."""
        return (~self.free).astype(np.uint8)

    def clearance(self) -> np.ndarray:
        """float32 per cell: distance in cells from its centre to the nearest blocked cell centre or cell beyond the
        map. Every cell closer than that is free, so the beam model's ray casting may jump over them."""
        padded = np.zeros((self.height + 2, self.width + 2), dtype=bool)
        padded[1:-1, 1:-1] = self.free
        return ndimage.distance_transform_edt(padded)[1:-1, 1:-1].astype(np.float32)
