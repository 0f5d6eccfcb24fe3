"""StaticLayer: costs from an OccupancyGrid map (docs/reference.md §2.4).

The ROS shell hands over the grid as an int8 array [height, width] plus its geometry; in a rolling
costmap it also sets `global_to_map`, the (x, y, yaw) transform taking global-frame points into the
map frame.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.parameters import param
from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.layer import Bounds, CostmapLayer
from simplebot_navigation.costmap.plugins import LayerSpec

_log = logging.getLogger(__name__)


@dataclass
class StaticLayerParams:
    map_topic: str = param("map", "", "OccupancyGrid topic", restart=True)
    first_map_only: bool = param(False, "", "keep the first map and ignore later ones")
    subscribe_to_updates: bool = param(False, "", "apply OccupancyGridUpdate messages", restart=True)
    track_unknown_space: bool = param(True, "", "unknown map cells stay unknown")
    use_maximum: bool = param(False, "", "combine by maximum instead of overwriting")
    lethal_cost_threshold: int = param(100, "", "map values at or above are lethal", rounds=True)
    unknown_cost_value: int = param(-1, "", "map value that means unknown", rounds=True)
    trinary_costmap: bool = param(True, "", "map to free/lethal/unknown only")
    enabled: bool = param(True, "", "the layer takes part in updates")


class StaticLayer(CostmapLayer):
    def __init__(self, name: str, map_topic: str = "map", first_map_only: bool = False,
                 subscribe_to_updates: bool = False, track_unknown_space: bool = True,
                 use_maximum: bool = False, lethal_cost_threshold: int = 100, unknown_cost_value: int = -1,
                 trinary_costmap: bool = True, enabled: bool = True):
        super().__init__(name)
        self.map_topic = map_topic
        self.first_map_only = bool(first_map_only)
        self.subscribe_to_updates = bool(subscribe_to_updates)
        self.track_unknown_space = bool(track_unknown_space)
        self.use_maximum = bool(use_maximum)
        self.lethal_threshold = max(min(int(lethal_cost_threshold), 100), 0)
        self.unknown_cost_value = int(unknown_cost_value) & 0xFF   # stored as unsigned char
        self.trinary_costmap = bool(trinary_costmap)
        self.enabled = bool(enabled)
        self.map_received = False
        self._values = np.zeros((0, 0), np.int8)   # the map as received (OccupancyGrid values), for reconfigure
        self.has_updated_data = False
        self.map_frame = ""
        self.global_to_map: tuple[float, float, float] | None = None
        self._window = (0, 0, 0, 0)

    def reconfigure(self, first_map_only: bool, track_unknown_space: bool, use_maximum: bool,
                    lethal_cost_threshold: int, unknown_cost_value: int, trinary_costmap: bool, enabled: bool) -> None:
        """A run-time change: the map held is read again with the new rules and applied in full next update."""
        before = (self.track_unknown_space, self.lethal_threshold, self.unknown_cost_value, self.trinary_costmap,
                  self.use_maximum, self.enabled)
        self.first_map_only = bool(first_map_only)
        self.track_unknown_space = bool(track_unknown_space)
        self.use_maximum = bool(use_maximum)
        self.lethal_threshold = max(min(int(lethal_cost_threshold), 100), 0)
        self.unknown_cost_value = int(unknown_cost_value) & 0xFF
        self.trinary_costmap = bool(trinary_costmap)
        self.enabled = bool(enabled)
        after = (self.track_unknown_space, self.lethal_threshold, self.unknown_cost_value, self.trinary_costmap,
                 self.use_maximum, self.enabled)
        if after != before and self.map_received:
            self.costmap[:, :] = self.interpret_values(self._values)
            self._window = (0, 0, self.size_x, self.size_y)
            self.has_updated_data = True

    def match_size(self) -> None:
        if not self.layered_costmap.rolling_window:
            super().match_size()

    def interpret_values(self, data) -> np.ndarray:
        """OccupancyGrid values (int8) -> costs, with unknown, lethal threshold and trinary rules."""
        v = np.asarray(data).astype(np.int8).view(np.uint8)
        if self.lethal_threshold == 0:
            scaled = np.zeros(v.shape, dtype=np.uint8)
        else:
            scaled = (v.astype(float) / self.lethal_threshold * LETHAL_OBSTACLE).astype(np.uint8)
        graded = np.full(v.shape, FREE_SPACE, np.uint8) if self.trinary_costmap else scaled
        out = np.where(v >= self.lethal_threshold, np.uint8(LETHAL_OBSTACLE), graded)
        unknown = NO_INFORMATION if self.track_unknown_space else FREE_SPACE
        return np.where(v == self.unknown_cost_value, np.uint8(unknown), out).astype(np.uint8)

    def incoming_map(self, data, resolution: float, origin_x: float, origin_y: float, frame_id: str = "") -> None:
        """A full map: int8 array shaped [height, width] (row-major as in nav_msgs/OccupancyGrid)."""
        grid = np.asarray(data)
        if grid.ndim != 2:
            raise ValueError(f"static layer {self.name!r}: map data must be 2-D [height, width], got {grid.shape}")
        size_y, size_x = grid.shape
        layered = self.layered_costmap
        master = layered.costmap
        geometry = (size_x, size_y, float(resolution), float(origin_x), float(origin_y))
        if not layered.rolling_window and geometry != (master.size_x, master.size_y, master.resolution,
                                                       master.origin_x, master.origin_y):
            layered.resize_map(*geometry, size_locked=True)
        elif geometry != (self.size_x, self.size_y, self.resolution, self.origin_x, self.origin_y):
            self.resize_map(*geometry)
        self._values = grid.astype(np.int8, copy=True)
        self.costmap[:, :] = self.interpret_values(grid)
        self.map_frame = frame_id.lstrip("/")
        self._window = (0, 0, self.size_x, self.size_y)
        self.map_received = True
        self.has_updated_data = True

    def incoming_update(self, x: int, y: int, data) -> None:
        """An OccupancyGridUpdate: int8 array [height, width] placed at cell (x, y)."""
        patch = np.asarray(data)
        h, w = patch.shape
        if x < 0 or y < 0 or x + w > self.size_x or y + h > self.size_y:
            raise ValueError(f"static layer {self.name!r}: update {w}x{h} at ({x}, {y}) does not fit "
                             f"the {self.size_x}x{self.size_y} map")
        self._values[y:y + h, x:x + w] = patch
        self.costmap[y:y + h, x:x + w] = self.interpret_values(patch)
        self._window = (x, y, w, h)
        self.has_updated_data = True

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float, bounds: Bounds) -> None:
        if not self.layered_costmap.rolling_window:
            if not self.map_received or not (self.has_updated_data or self._extra is not None):
                return
        self.use_extra_bounds(bounds)
        x, y, w, h = self._window
        bounds.touch(*self.map_to_world(x, y))
        bounds.touch(*self.map_to_world(x + w, y + h))
        self.has_updated_data = False

    def update_costs(self, master, x0: int, y0: int, xn: int, yn: int) -> None:
        if not self.map_received:
            return
        if not self.layered_costmap.rolling_window:
            if self.use_maximum:
                self.update_with_max(master, x0, y0, xn, yn)
            else:
                self.update_with_true_overwrite(master, x0, y0, xn, yn)
            return
        if self.global_to_map is None:
            # As costmap_2d when the map frame cannot be looked up: this cycle goes without the map.
            _log.warning("static layer %s: no transform from the global frame to %s yet; map not applied",
                         self.name, self.map_frame or "the map frame")
            return
        tx, ty, yaw = self.global_to_map
        ii, jj = np.meshgrid(np.arange(x0, xn), np.arange(y0, yn))
        wx, wy = master.origin_x + (ii + 0.5) * master.resolution, master.origin_y + (jj + 0.5) * master.resolution
        c, s = math.cos(yaw), math.sin(yaw)
        mx, my, inside = self.world_to_map_array(tx + c * wx - s * wy, ty + s * wx + c * wy)
        values = self.costmap[my[inside], mx[inside]]
        dst = master.costmap[y0:yn, x0:xn]
        dst[inside] = np.maximum(values, dst[inside]) if self.use_maximum else values

    def reset(self) -> None:
        """costmap_2d re-reads the map unless first_map_only; here the held map is re-applied in full."""
        self.has_updated_data = True
        if not self.first_map_only:
            self._window = (0, 0, self.size_x, self.size_y)


SPEC = LayerSpec.builtin(StaticLayer, StaticLayerParams, ("map_topic", "unknown_cost_value", "lethal_cost_threshold",
                                                          "track_unknown_space"))
