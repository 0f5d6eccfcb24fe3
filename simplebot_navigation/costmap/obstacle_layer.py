"""ObstacleLayer: marks sensor hits and clears along sensor rays (docs/reference.md §2.5, docs/design.md §9).

Sensor data arrives as plain `Observation`s already expressed in the costmap's global frame; the ROS
shell does the TF lookups and message conversion, using `laser_scan_to_observation` or
`point_cloud_to_observation`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from simplebot_navigation.laser_scan import scan_problem
from simplebot_navigation.parameters import param
from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.footprint import transform_footprint
from simplebot_navigation.costmap.layer import Bounds, CostmapLayer

_log = logging.getLogger(__name__)

SUPPORTED_DATA_TYPES = ("LaserScan", "PointCloud2")

#: inf_is_valid turns +inf into a ray this much shorter than range_max, as costmap_2d does.
INF_RANGE_EPSILON = 1e-4


@dataclass
class ObservationSourceParams:
    """``<layer>/<source>/``: one sensor of an obstacle layer."""
    topic: str = param("", "", "topic (default: the source's name)", restart=True)
    sensor_frame: str = param("", "", "frame of the sensor (default: the message's frame)", restart=True)
    data_type: str = param("PointCloud", "", f"message type: {', '.join(SUPPORTED_DATA_TYPES)}", restart=True)
    marking: bool = param(True, "", "hits mark obstacles")
    clearing: bool = param(False, "", "rays clear free space")
    inf_is_valid: bool = param(False, "", "+inf ranges clear up to range_max")
    expected_update_rate: float = param(0.0, "s", "longest expected gap between messages (0: any)", ge=0)
    observation_persistence: float = param(0.0, "s", "how long readings are kept (0: the latest only)", ge=0)
    min_obstacle_height: float = param(0.0, "m", "hits below are ignored")
    max_obstacle_height: float = param(2.0, "m", "hits above are ignored")
    obstacle_range: float = param(2.5, "m", "hits farther than this do not mark (searched upwards)", ge=0)
    raytrace_range: float = param(3.0, "m", "rays clear up to this range (searched upwards)", ge=0)


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


@dataclass
class Observation:
    """One sensor reading in the global frame.

    `points` (N x 3) are hits: they clear along their ray and may mark. `clear_points` (M x 3) are
    ray ends that only clear (+inf laser returns with inf_is_valid).
    """
    origin: np.ndarray
    points: np.ndarray
    obstacle_range: float
    raytrace_range: float
    stamp: float
    clear_points: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))


@dataclass
class ObservationSource:
    """Parameters of one observation source (`<layer>/<source>/...`)."""
    name: str
    topic: str = ""
    sensor_frame: str = ""
    data_type: str = "PointCloud"
    marking: bool = True
    clearing: bool = False
    obstacle_range: float = 2.5
    raytrace_range: float = 3.0
    inf_is_valid: bool = False
    expected_update_rate: float = 0.0
    observation_persistence: float = 0.0
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 2.0

    def __post_init__(self):
        if not self.topic:
            self.topic = self.name
        if self.data_type not in SUPPORTED_DATA_TYPES:
            raise ValueError(f"observation source {self.name!r}: data_type {self.data_type!r} is not supported; "
                             f"use one of {', '.join(SUPPORTED_DATA_TYPES)}")


def laser_scan_to_observation(ranges, angle_min: float, angle_increment: float, range_min: float,
                              range_max: float, sensor_pose, stamp: float, obstacle_range: float,
                              raytrace_range: float, inf_is_valid: bool = False) -> Observation:
    """Project a LaserScan taken at sensor_pose = (x, y, z, yaw) in the global frame.

    Returns in [range_min, range_max) become hits, but never a negative one (whatever range_min
    says): NaN, negative and other out-of-range values are dropped. With inf_is_valid, +inf becomes
    a clearing-only ray of length range_max - 1e-4 that never marks (docs/design.md §9: costmap_2d would
    mark a phantom ring there). A scan whose geometry is unusable (see scan_problem) gives an empty
    observation; both kinds of drop are logged as warnings, which the ROS shell throttles.
    """
    r = np.asarray(ranges, dtype=float)
    sx, sy, sz, syaw = (float(v) for v in sensor_pose)
    origin = np.array([sx, sy, sz])
    problem = scan_problem(r, angle_min, angle_increment, range_min, range_max, sensor_pose)
    if problem:
        field, why = problem
        _log.warning("LaserScan dropped: %s", why, extra={"throttle_key": field})
        return Observation(origin, np.empty((0, 3)), float(obstacle_range), float(raytrace_range), float(stamp))
    angles = syaw + angle_min + angle_increment * np.arange(len(r))
    with np.errstate(invalid="ignore"):
        negative = r < 0
        hit = (r >= max(range_min, 0.0)) & (r < range_max)
    if negative.any():
        _log.warning("LaserScan: %d negative ranges dropped (a range is never below 0, whatever range_min "
                     "says; range_min is %s)", int(negative.sum()), range_min)

    def project(rr, aa):
        return np.stack([sx + rr * np.cos(aa), sy + rr * np.sin(aa), np.full(len(rr), sz)], axis=1)

    points = project(r[hit], angles[hit])
    clear = np.empty((0, 3))
    if inf_is_valid:
        inf = np.isposinf(r)
        clear_range = range_max - INF_RANGE_EPSILON
        if clear_range >= range_min:
            clear = project(np.full(int(inf.sum()), clear_range), angles[inf])
    return Observation(origin, points, float(obstacle_range), float(raytrace_range), float(stamp), clear)


def point_cloud_to_observation(points_xyz, sensor_origin, stamp: float, obstacle_range: float,
                               raytrace_range: float) -> Observation:
    """Observation from cloud points already in the global frame; non-finite points are dropped."""
    pts = np.asarray(points_xyz, dtype=float).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(axis=1)]
    return Observation(np.asarray(sensor_origin, dtype=float).reshape(3), pts, float(obstacle_range),
                       float(raytrace_range), float(stamp))


class ObservationBuffer:
    """Recent observations of one source, with costmap_2d's persistence and staleness rules."""

    def __init__(self, source: ObservationSource, now: float):
        self.source = source
        self.observations: list[Observation] = []   # newest first
        self.last_updated = float(now)

    def buffer_observation(self, observation: Observation, now: float) -> None:
        """Store an observation after dropping points outside [min, max]_obstacle_height (global z)."""
        lo, hi = self.source.min_obstacle_height, self.source.max_obstacle_height

        def keep(p):
            return p[(p[:, 2] <= hi) & (p[:, 2] >= lo)]

        filtered = Observation(observation.origin, keep(observation.points), observation.obstacle_range,
                               observation.raytrace_range, observation.stamp, keep(observation.clear_points))
        self.observations.insert(0, filtered)
        self.last_updated = float(now)
        self._purge_stale()

    def _purge_stale(self) -> None:
        keep_time = self.source.observation_persistence
        if keep_time == 0.0:
            del self.observations[1:]
            return
        for i, obs in enumerate(self.observations):
            if self.last_updated - obs.stamp > keep_time:
                del self.observations[i:]
                return

    def get_observations(self) -> list[Observation]:
        self._purge_stale()
        return list(self.observations)

    def is_current(self, now: float, update_period: float) -> bool:
        """Current if the last observation came within expected_update_rate plus one costmap update
        period (docs/design.md §9); an expected_update_rate of 0 means always current."""
        rate = self.source.expected_update_rate
        if rate == 0.0:
            return True
        return now - self.last_updated <= rate + update_period

    def reset_last_updated(self, now: float) -> None:
        self.last_updated = float(now)


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


__all__ = ["Observation", "ObservationSource", "ObservationBuffer", "ObstacleLayer",
           "laser_scan_to_observation", "point_cloud_to_observation", "SUPPORTED_DATA_TYPES"]
