"""Layer interface and the grid-backed CostmapLayer with costmap_2d's combination rules (docs/reference.md §2.3).

Every hook is called by the costmap's update (LayeredCostmap.update_map) on the thread that updates it (the
costmap's own update thread in move_base), with the costmap's lock held, so a layer needs no lock of its own
for state only its hooks touch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from simplebot_navigation.costmap.cost_values import NO_INFORMATION
from simplebot_navigation.costmap.costmap_2d import Costmap2D


@dataclass
class Bounds:
    """World-frame update bounds that layers may only grow (an empty box starts at +-1e30)."""
    min_x: float = 1e30
    min_y: float = 1e30
    max_x: float = -1e30
    max_y: float = -1e30

    def touch(self, x: float, y: float) -> None:
        self.min_x = min(self.min_x, x)
        self.min_y = min(self.min_y, y)
        self.max_x = max(self.max_x, x)
        self.max_y = max(self.max_y, y)

    def touch_points(self, xs: np.ndarray, ys: np.ndarray) -> None:
        if len(xs):
            self.touch(float(np.min(xs)), float(np.min(ys)))
            self.touch(float(np.max(xs)), float(np.max(ys)))

    def as_tuple(self) -> tuple[float, float, float, float]:
        return (self.min_x, self.min_y, self.max_x, self.max_y)


class Layer:
    """One plugin of a LayeredCostmap (costmap_2d's Layer). Subclasses override the hooks they need.

    Built as ``cls(name, **params)``, params as its registration (a LayerSpec, costmap/plugins.py) resolves
    them from its namespace: the fields of its parameter class."""

    def __init__(self, name: str):
        self.name = name
        self.enabled = True
        self.current = True
        self.layered_costmap = None

    def initialize(self, layered_costmap) -> None:
        """Added to a costmap: keep it, then on_initialize()."""
        self.layered_costmap = layered_costmap
        self.on_initialize()

    def on_initialize(self) -> None:
        """Once, after the costmap is known (its size may still change: see match_size)."""

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float, bounds: Bounds) -> None:
        """First pass of an update, robot pose in the costmap's frame: take in new data and grow ``bounds``
        (world frame) to cover every cell this layer will change."""

    def update_costs(self, master: Costmap2D, x0: int, y0: int, xn: int, yn: int) -> None:
        """Second pass, in plugin order: write this layer's costs into ``master`` for cells [x0, xn) x [y0, yn)."""

    def reset(self) -> None:
        """Forget everything learned (clear_costmaps, a jump back in time)."""

    def reconfigure(self, **params) -> None:
        """Live parameter changes. ``params`` are all the layer's parameters that may change while running
        (its registration's ``live_params``: the fields not restart-only, already checked), changed or not.
        Called by CostmapCore.reconfigure on every layer of a costmap whose parameters changed, on the thread
        that applies the change (move_base's executor, at the start of a control cycle) with the costmap's lock
        held, so between two updates. Base: each value becomes the attribute of its name; a layer with state
        derived from them overrides this."""
        for key, value in params.items():
            setattr(self, key, value)

    def is_current(self) -> bool:
        """Its inputs are fresh: move_base refuses to drive on a costmap with a stale layer."""
        return self.current

    def on_footprint_changed(self) -> None:
        """The costmap's footprint (self.footprint) changed."""

    def match_size(self) -> None:
        """The costmap's size, resolution or origin changed (a map arrived, a rolling window moved)."""

    @property
    def footprint(self) -> np.ndarray:
        return self.layered_costmap.footprint


@runtime_checkable
class MapLayer(Protocol):
    """A layer that reads an OccupancyGrid topic; the costmap's ROS shell subscribes and calls these."""
    map_topic: str
    subscribe_to_updates: bool     # also read <map_topic>_updates
    first_map_only: bool
    map_received: bool

    def incoming_map(self, data, resolution: float, origin_x: float, origin_y: float, frame_id: str = "") -> None:
        """A whole map: int8 cells, row-major from the origin (ValueError: refused, with the reason)."""

    def incoming_update(self, x: int, y: int, data) -> None:
        """A rectangle of cells from column x, row y (ValueError: refused, with the reason)."""


@runtime_checkable
class SensorLayer(Protocol):
    """A layer fed by observation sources (costmap/observation.py); its registration is a SensorLayerSpec,
    whose hooks resolve, declare and pass on the sources' parameters. The ROS shell subscribes each source's
    topic and hands every message, as an Observation in the costmap's frame, to the costmap, which routes it
    here by source name; staleness is read from the buffers. Called with the costmap's lock held, from the
    sensor callbacks and the costmap's update."""
    buffers: dict                  # source name -> ObservationBuffer: its source, observations, last message
    stale_sources: list            # the sources that made the last update not current (is_current False)

    def add_observation(self, source_name: str, observation) -> None:
        """One sensor message of a source as an Observation in the costmap's frame."""

    def clear_observations(self) -> None:
        """Drop every buffered observation (time jumped back)."""


@runtime_checkable
class MovingObstacleClearing(Protocol):
    """A layer whose marks of moving obstacles are cleared after them (docs/reference.md §6.3)."""

    def set_clearing_circles(self, circles) -> None:
        """Where moving obstacles are and just were ((K, 3) x, y, radius in the costmap's frame): clear the marks
        within them from the next update on, until the next call."""


class CostmapLayer(Layer, Costmap2D):
    """A layer that keeps its own grid, aligned with the master, and merges it into a window of the master."""

    def __init__(self, name: str, default_value: int = 0):
        Layer.__init__(self, name)
        Costmap2D.__init__(self, 0, 0, 1.0, 0.0, 0.0, default_value)
        self._extra = None

    def on_initialize(self) -> None:
        self.match_size()

    def match_size(self) -> None:
        master = self.layered_costmap.costmap
        self.resize_map(master.size_x, master.size_y, master.resolution, master.origin_x, master.origin_y)

    def add_extra_bounds(self, min_x: float, min_y: float, max_x: float, max_y: float) -> None:
        """Ask for a region to be updated on the next cycle (e.g. after clearing part of this layer)."""
        if self._extra is None:
            self._extra = Bounds()
        self._extra.touch(min_x, min_y)
        self._extra.touch(max_x, max_y)

    def use_extra_bounds(self, bounds: Bounds) -> None:
        if self._extra is not None:
            bounds.touch(self._extra.min_x, self._extra.min_y)
            bounds.touch(self._extra.max_x, self._extra.max_y)
            self._extra = None

    def reset(self) -> None:
        self.reset_maps()

    def clear_area(self, start_x: int, start_y: int, end_x: int, end_y: int, invert_area: bool = False) -> None:
        """Set to NO_INFORMATION every cell outside the open box (start_x, end_x) x (start_y, end_y),
        or inside it with invert_area (what clear_costmap_recovery does to a layer)."""
        xs = np.arange(self.size_x)
        ys = np.arange(self.size_y)
        inside = ((ys[:, None] > start_y) & (ys[:, None] < end_y)) & ((xs > start_x) & (xs < end_x))
        self.costmap[inside == invert_area] = NO_INFORMATION

    # -- combination with the master grid, over [x0, xn) x [y0, yn) ----------------
    def update_with_true_overwrite(self, master: Costmap2D, x0: int, y0: int, xn: int, yn: int) -> None:
        master.costmap[y0:yn, x0:xn] = self.costmap[y0:yn, x0:xn]

    def update_with_overwrite(self, master: Costmap2D, x0: int, y0: int, xn: int, yn: int) -> None:
        layer = self.costmap[y0:yn, x0:xn]
        dst = master.costmap[y0:yn, x0:xn]
        known = layer != NO_INFORMATION
        dst[known] = layer[known]

    def update_with_max(self, master: Costmap2D, x0: int, y0: int, xn: int, yn: int) -> None:
        """A known layer value replaces an unknown master cell, even FREE; otherwise the larger wins."""
        layer = self.costmap[y0:yn, x0:xn]
        dst = master.costmap[y0:yn, x0:xn]
        take = (layer != NO_INFORMATION) & ((dst == NO_INFORMATION) | (dst < layer))
        dst[take] = layer[take]

