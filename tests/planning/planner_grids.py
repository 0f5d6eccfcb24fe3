"""Test grids for the global planner: Costmap2D builders and a small inflation helper."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt

from simplebot_navigation.costmap.cost_values import (INSCRIBED_INFLATED_OBSTACLE,
                                                      LETHAL_OBSTACLE)
from simplebot_navigation.costmap.costmap_2d import Costmap2D


def free_map(size_x: int = 60, size_y: int = 40, resolution: float = 0.1,
             origin=(0.0, 0.0)) -> Costmap2D:
    return Costmap2D(size_x, size_y, resolution, origin[0], origin[1])


def inflate(costmap: Costmap2D, inscribed_radius: float, inflation_radius: float,
            cost_scaling_factor: float) -> None:
    """InflationLayer costs from the exact distance to the nearest lethal cell (docs/reference.md §2.6)."""
    grid = costmap.costmap
    lethal = grid == LETHAL_OBSTACLE
    if not lethal.any():
        return
    d = distance_transform_edt(~lethal) * costmap.resolution
    cost = np.zeros(grid.shape, dtype=np.float64)
    ring = (d > inscribed_radius) & (d <= inflation_radius)
    cost[ring] = np.trunc(252 * np.exp(-cost_scaling_factor * (d[ring] - inscribed_radius)))
    cost[(d <= inscribed_radius) & ~lethal] = INSCRIBED_INFLATED_OBSTACLE
    grid[:] = np.maximum(grid, cost.astype(np.uint8))


def cells_of(costmap: Costmap2D, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    mx, my, valid = costmap.world_to_map_array(poses[:, 0], poses[:, 1])
    assert valid.all()
    return mx, my


def costs_along(costmap: Costmap2D, poses: np.ndarray) -> np.ndarray:
    mx, my = cells_of(costmap, poses)
    return costmap.costmap[my, mx]
