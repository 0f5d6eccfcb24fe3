"""ObstacleLayer: marks sensor hits and clears along sensor rays (docs/reference.md §2.5, docs/design.md §9).

A sensor layer: its observation sources (costmap/observation.py) bring plain `Observation`s already expressed
in the costmap's global frame; the ROS shell does the TF lookups and message conversion.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.parameters import param
from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.footprint import transform_footprint
from simplebot_navigation.costmap.layer import Bounds, CostmapLayer
from simplebot_navigation.costmap.observation import Observation, ObservationBuffer, SensorLayerSpec

_log = logging.getLogger(__name__)


@dataclass
class ObstacleLayerParams:
    observation_sources: str = param("", "", "space-separated names of the sensor sub-namespaces", restart=True)
    track_unknown_space: bool = param(False, "", "keep unseen cells unknown (default: the costmap's)",
                                      restart=True)
    max_obstacle_height: float = param(2.0, "m", "hits above are ignored")
    combination_method: int = param(1, "", "0: overwrite the master grid, 1: maximum, other: not combined",
                                    rounds=True)
    footprint_clearing_enabled: bool = param(True, "", "clear the cells under the robot")
    enabled: bool = param(True, "", "the layer takes part in updates")


class ObstacleLayer(CostmapLayer):
    """Marks observation hits as LETHAL after clearing every clearing ray, then merges into the master."""

    def __init__(self, name: str, sources=(), track_unknown_space: bool | None = None,
                 max_obstacle_height: float = 2.0, combination_method: int = 1,
                 footprint_clearing_enabled: bool = True, enabled: bool = True):
        super().__init__(name)
        self.sources = list(sources)
        self._track_unknown = track_unknown_space
        self.max_obstacle_height = float(max_obstacle_height)
        self.combination_method = int(combination_method)
        self.footprint_clearing_enabled = bool(footprint_clearing_enabled)
        self.enabled = bool(enabled)
        self.buffers: dict[str, ObservationBuffer] = {}
        self.transformed_footprint = np.empty((0, 2))
        self.stale_sources: list[str] = []
        self.clearing_circles = np.empty((0, 3))

    def reconfigure(self, sources: dict[str, dict] | None = None, **params) -> None:
        """A run-time change: the layer's own flags (max_obstacle_height, combination_method,
        footprint_clearing_enabled, enabled) and, by source name, fields of its observation sources
        (ranges, marking, clearing, heights, rates). Later scans and updates use them; the sources
        themselves (names, topics, frames, data types) stay."""
        for key, value in params.items():
            setattr(self, key, type(getattr(self, key))(value))
        for name, values in (sources or {}).items():
            for key, value in values.items():
                setattr(self.buffers[name].source, key, value)

    def on_initialize(self) -> None:
        layered = self.layered_costmap
        track = layered.track_unknown_space if self._track_unknown is None else self._track_unknown
        self.default_value = NO_INFORMATION if track else FREE_SPACE
        self.match_size()
        now = layered.clock()
        for source in self.sources:
            if source.name in self.buffers:
                raise ValueError(f"layer {self.name!r}: observation source {source.name!r} is listed twice")
            self.buffers[source.name] = ObservationBuffer(source, now)

    def add_observation(self, source_name: str, observation: Observation) -> None:
        try:
            buffer = self.buffers[source_name]
        except KeyError:
            raise KeyError(f"layer {self.name!r} has no observation source {source_name!r}; "
                           f"sources are {list(self.buffers)}") from None
        if not np.isfinite(observation.origin).all():
            # Raytracing from a NaN origin has no start cell; the data is dropped, not the layer.
            _log.warning("layer %r, observation source %r: observation dropped, its sensor origin %s "
                         "is not finite", self.name, source_name, observation.origin.tolist())
            return
        buffer.buffer_observation(observation, self.layered_costmap.clock())

    def _gather(self):
        """Marking then clearing observations; as in costmap_2d, a stale marking source suppresses
        this cycle's clearing (the second gather is short-circuited)."""
        now = self.layered_costmap.clock()
        period = self.layered_costmap.update_period
        marking, clearing, stale = [], [], []
        for want_marking, out in ((True, marking), (False, clearing)):
            if stale:
                break
            for name, buffer in self.buffers.items():
                if (buffer.source.marking if want_marking else buffer.source.clearing):
                    out.extend(buffer.get_observations())
                    if not buffer.is_current(now, period) and name not in stale:
                        stale.append(name)
        return marking, clearing, stale

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float, bounds: Bounds) -> None:
        if self.layered_costmap.rolling_window:
            self.update_origin(robot_x - self.size_in_meters_x / 2, robot_y - self.size_in_meters_y / 2)
        self.use_extra_bounds(bounds)
        marking, clearing, self.stale_sources = self._gather()
        self.current = not self.stale_sources
        for observation in clearing:
            self._raytrace_freespace(observation, bounds)
        for observation in marking:
            self._mark(observation, bounds)
        self._clear_circles(bounds)
        if self.footprint_clearing_enabled:
            self.transformed_footprint = transform_footprint(self.footprint, robot_x, robot_y, robot_yaw)
            bounds.touch_points(self.transformed_footprint[:, 0], self.transformed_footprint[:, 1])

    def _mark(self, observation: Observation, bounds: Bounds) -> None:
        p = observation.points
        if not len(p):
            return
        d = p - observation.origin
        ok = (p[:, 2] <= self.max_obstacle_height) & \
             (np.einsum("ij,ij->i", d, d) < observation.obstacle_range ** 2)
        p = p[ok]
        mx, my, inside = self.world_to_map_array(p[:, 0], p[:, 1])
        self.costmap[my[inside], mx[inside]] = LETHAL_OBSTACLE
        bounds.touch_points(p[inside, 0], p[inside, 1])

    def set_clearing_circles(self, circles) -> None:
        """Circles (K, 3: x, y, radius in the global frame) where moving obstacles are or just were: every update
        from now on clears the marks within them, widened by one cell, after marking (docs/reference.md §6.3).
        Rows that are not finite or have a negative radius are dropped."""
        c = np.asarray(circles, dtype=float).reshape(-1, 3)
        self.clearing_circles = c[np.isfinite(c).all(axis=1) & (c[:, 2] >= 0)]

    def _clear_circles(self, bounds: Bounds) -> None:
        """LETHAL cells whose centre lies within a clearing circle (plus one cell) become FREE; unknown and free
        cells stay as they are."""
        c = self.clearing_circles
        if not len(c):
            return
        radius = c[:, 2] + self.resolution
        xs, ys = self.cells_within_circles(c[:, 0], c[:, 1], radius)
        marked = self.costmap[ys, xs] == LETHAL_OBSTACLE
        self.costmap[ys[marked], xs[marked]] = FREE_SPACE
        bounds.touch_points(np.concatenate([c[:, 0] - radius, c[:, 0] + radius]),
                            np.concatenate([c[:, 1] - radius, c[:, 1] + radius]))

    def _raytrace_freespace(self, observation: Observation, bounds: Bounds) -> None:
        ox, oy = float(observation.origin[0]), float(observation.origin[1])
        start = self.world_to_map(ox, oy)
        if start is None:
            _log.warning("The origin for the sensor at (%.2f, %.2f) is out of map bounds. "
                         "So, the costmap cannot raytrace for it.", ox, oy)
            return
        ends = observation.points if not len(observation.clear_points) else \
            np.concatenate([observation.points, observation.clear_points])
        bounds.touch(ox, oy)
        if not len(ends):
            return
        wx, wy = self._clip_to_map(ox, oy, ends[:, 0].copy(), ends[:, 1].copy())
        mx, my, inside = self.world_to_map_array(wx, wy)
        wx, wy, mx, my = wx[inside], wy[inside], mx[inside], my[inside]
        cx, cy = self.raytrace_cells(start[0], start[1], mx, my,
                                     self.cell_distance(observation.raytrace_range))
        self.costmap[cy, cx] = FREE_SPACE
        # Bounds grow to each ray end, pulled back to raytrace_range.
        dx, dy = wx - ox, wy - oy
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.minimum(1.0, observation.raytrace_range / np.hypot(dx, dy))
        scale = np.where(np.isnan(scale), 1.0, scale)
        bounds.touch_points(ox + dx * scale, oy + dy * scale)

    def _clip_to_map(self, ox: float, oy: float, wx: np.ndarray, wy: np.ndarray):
        """Shorten rays that leave the map to end on its edge (the far edges 1 mm inside), as costmap_2d does."""
        a, b = wx - ox, wy - oy
        x_lo, y_lo = self.origin_x, self.origin_y
        x_hi = x_lo + self.size_x * self.resolution
        y_hi = y_lo + self.size_y * self.resolution
        with np.errstate(divide="ignore", invalid="ignore"):
            m = wx < x_lo
            t = (x_lo - ox) / a[m]
            wx[m], wy[m] = x_lo, oy + b[m] * t
            m = wy < y_lo
            t = (y_lo - oy) / b[m]
            wx[m], wy[m] = ox + a[m] * t, y_lo
            m = wx > x_hi
            t = (x_hi - ox) / a[m]
            wx[m], wy[m] = x_hi - 0.001, oy + b[m] * t
            m = wy > y_hi
            t = (y_hi - oy) / b[m]
            wx[m], wy[m] = ox + a[m] * t, y_hi - 0.001
        return wx, wy

    def update_costs(self, master, x0: int, y0: int, xn: int, yn: int) -> None:
        if self.footprint_clearing_enabled and len(self.transformed_footprint):
            self.set_convex_polygon_cost(self.transformed_footprint, FREE_SPACE)
        if self.combination_method == 0:
            self.update_with_overwrite(master, x0, y0, xn, yn)
        elif self.combination_method == 1:
            self.update_with_max(master, x0, y0, xn, yn)

    def reset(self) -> None:
        self.reset_maps()
        self.current = True
        self.stale_sources = []
        self.clearing_circles = np.empty((0, 3))
        now = self.layered_costmap.clock()
        for buffer in self.buffers.values():
            buffer.reset_last_updated(now)

    def clear_observations(self) -> None:
        for buffer in self.buffers.values():
            buffer.observations.clear()



SPEC = SensorLayerSpec.builtin(ObstacleLayer, ObstacleLayerParams, ("max_obstacle_height", "raytrace_range",
                                                                    "obstacle_range", "track_unknown_space"),
                               costmap_defaults=("track_unknown_space",))
