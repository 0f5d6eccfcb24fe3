"""LayeredCostmap: the master grid and the bounds-based layer update of costmap_2d (docs/reference.md §2.3)."""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from simplebot_navigation.costmap.cost_values import FREE_SPACE, NO_INFORMATION
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.footprint import footprint_radii
from simplebot_navigation.costmap.layer import Bounds, Layer, SensorLayer

_log = logging.getLogger(__name__)


class LayeredCostmap:
    """Master grid plus an ordered list of layers.

    `clock` returns the current time in seconds (the ROS shell passes its node clock so that
    sensor staleness follows simulated time); `update_period` is one costmap update cycle,
    used by the observation sources' is-current slack (docs/design.md §9).
    """

    def __init__(self, rolling_window: bool = False, track_unknown_space: bool = False,
                 size_x: int = 0, size_y: int = 0, resolution: float = 0.05,
                 origin_x: float = 0.0, origin_y: float = 0.0, clock=time.monotonic,
                 update_period: float = 0.0):
        self.rolling_window = bool(rolling_window)
        self.track_unknown_space = bool(track_unknown_space)
        default = NO_INFORMATION if track_unknown_space else FREE_SPACE
        self.costmap = Costmap2D(size_x, size_y, resolution, origin_x, origin_y, default)
        self.plugins: list[Layer] = []
        self.clock = clock
        self.update_period = float(update_period)
        self.size_locked = False
        self.initialized = False
        self.footprint = np.empty((0, 2))
        self.inscribed_radius = math.inf
        self.circumscribed_radius = 0.0
        #: world bounds and cell window [x0, xn) x [y0, yn) of the last update_map that wrote cells
        #: (an empty cycle keeps the previous window, as costmap_2d's getBounds)
        self.bounds = Bounds()
        self.update_window: tuple[int, int, int, int] | None = None

    def add_plugin(self, layer: Layer) -> None:
        self.plugins.append(layer)
        layer.initialize(self)

    def resize_map(self, size_x: int, size_y: int, resolution: float, origin_x: float, origin_y: float,
                   size_locked: bool = False) -> None:
        self.size_locked = size_locked
        self.costmap.resize_map(size_x, size_y, resolution, origin_x, origin_y)
        for layer in self.plugins:
            layer.match_size()

    def update_map(self, robot_x: float, robot_y: float, robot_yaw: float) -> None:
        """One cycle: grow bounds through the enabled layers, reset that window, then let each layer write it."""
        master = self.costmap
        if self.rolling_window:
            master.update_origin(robot_x - master.size_in_meters_x / 2, robot_y - master.size_in_meters_y / 2)
        if not self.plugins:
            return
        bounds = Bounds()
        for layer in self.plugins:
            if not layer.enabled:
                continue
            before = bounds.as_tuple()
            layer.update_bounds(robot_x, robot_y, robot_yaw, bounds)
            if (bounds.min_x > before[0] or bounds.min_y > before[1]
                    or bounds.max_x < before[2] or bounds.max_y < before[3]):
                _log.warning("Illegal bounds change, was %s but is now %s. The offending layer is %s",
                             before, bounds.as_tuple(), layer.name)
        self.bounds = bounds
        x0, y0 = master.world_to_map_enforce_bounds(bounds.min_x, bounds.min_y)
        xn, yn = master.world_to_map_enforce_bounds(bounds.max_x, bounds.max_y)
        x0, y0 = max(0, x0), max(0, y0)
        xn, yn = min(master.size_x, xn + 1), min(master.size_y, yn + 1)
        if xn < x0 or yn < y0:
            return
        master.reset_map(x0, y0, xn, yn)
        for layer in self.plugins:
            if layer.enabled:
                layer.update_costs(master, x0, y0, xn, yn)
        self.update_window = (x0, y0, xn, yn)
        self.initialized = True

    def is_current(self) -> bool:
        return all(layer.is_current() for layer in self.plugins if layer.enabled)

    def stale_sources(self) -> list[str]:
        """'<layer>/<source>' for every observation source that made the costmap not current."""
        return [f"{layer.name}/{source}" for layer in self.plugins
                if layer.enabled and isinstance(layer, SensorLayer) for source in layer.stale_sources]

    def set_footprint(self, footprint) -> None:
        """Set the padded footprint; layers that depend on its radii (inflation) recompute."""
        self.footprint = np.asarray(footprint, dtype=float).reshape(-1, 2)
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.footprint)
        for layer in self.plugins:
            layer.on_footprint_changed()

    def reset_layers(self) -> None:
        self.costmap.reset_maps()
        for layer in self.plugins:
            layer.reset()

    def layer(self, name: str) -> Layer:
        for layer in self.plugins:
            if layer.name == name:
                return layer
        raise KeyError(f"no layer named {name!r}; layers are {[p.name for p in self.plugins]}")
