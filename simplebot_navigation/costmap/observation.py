"""Observation sources: how a sensor layer (an ObstacleLayer, or any layer that satisfies ``SensorLayer``) is fed.

A sensor layer's namespace names its sources in ``observation_sources``, each with a sub-namespace of
ObservationSourceParams (topic, data type, ranges, ...), as costmap_2d's obstacle layer does. Its registration,
a ``SensorLayerSpec``, resolves and declares them and passes their live changes; the ROS shell subscribes each
source's topic, converts its messages with `laser_scan_to_observation` or `point_cloud_to_observation` into
`Observation`s already in the costmap's global frame, and the costmap routes them to the layer, which keeps each
source's in an `ObservationBuffer` (docs/reference.md §2.5, docs/design.md §9).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, fields

import numpy as np

from simplebot_navigation.costmap.plugins import LayerContext, LayerSpec
from simplebot_navigation.laser_scan import scan_problem
from simplebot_navigation.parameters import Param, ParameterError, fields_of, load, namespace, param

_log = logging.getLogger(__name__)

SUPPORTED_DATA_TYPES = ("LaserScan", "PointCloud2")

#: inf_is_valid turns +inf into a ray this much shorter than range_max, as costmap_2d does.
INF_RANGE_EPSILON = 1e-4


@dataclass
class ObservationSourceParams:
    """``<layer>/<source>/``: one sensor of a sensor layer."""
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


#: source keys found with searchParam (the source's namespace, its layer's, the costmap's, ...) when not set
SEARCHED_SOURCE_KEYS = ("obstacle_range", "raytrace_range")


@dataclass(frozen=True)
class SensorLayerSpec(LayerSpec):
    """The registration of a layer fed by observation sources. Its parameter class has an
    ``observation_sources`` field (space-separated names); each name is a sub-namespace of
    ObservationSourceParams. The layer is built with ``sources``, a list of ObservationSource instead of
    ``observation_sources``, and its ``reconfigure`` gets ``sources`` as {source name: {field: value}} with the
    fields that may change while running."""

    searched_keys = SEARCHED_SOURCE_KEYS

    def keys(self) -> dict[str, Param]:
        return {**fields_of(ObservationSourceParams), **fields_of(self.params)}

    def resolve(self, tree: dict, path: str, context: LayerContext) -> tuple[dict, list[str]]:
        names = tree.get("observation_sources", "")
        names = names.split() if isinstance(names, str) else []
        params, warnings = self.load_own(tree, path, context, also_known=[*SEARCHED_SOURCE_KEYS, *names])
        sources = [self._source(name, tree, path, context, warnings)
                   for name in params.pop("observation_sources").split()]
        if not sources:
            warnings.append(f"{path}: no observation_sources, so this layer will never see an obstacle")
        return {**params, "sources": sources}, warnings

    @staticmethod
    def _source(name: str, tree: dict, path: str, context: LayerContext, warnings: list) -> ObservationSource:
        src_path = f"{path}/{name}"
        src_tree = namespace(tree.get(name, {}), src_path)
        specs = fields_of(ObservationSourceParams)
        given, source_warnings = load(specs, src_tree, src_path)
        warnings += source_warnings
        src = {**{key: spec.default for key, spec in specs.items()}, **given}
        if src["data_type"] not in SUPPORTED_DATA_TYPES:
            hint = " (the default when data_type is not set)" if "data_type" not in src_tree else ""
            raise ParameterError(f"{src_path}/data_type: {src['data_type']!r}{hint} is not supported; "
                                 f"use one of {', '.join(SUPPORTED_DATA_TYPES)}")
        for key in SEARCHED_SOURCE_KEYS:
            src[key] = context.searched(key, specs[key], nearer=[(src_tree, src_path), (tree, path)])
        src["sensor_frame"] = src["sensor_frame"].lstrip("/")
        source = ObservationSource(name=name, **src)
        if source.inf_is_valid:
            warnings.append(f"{src_path}: inf_is_valid: +inf ranges clear up to range_max but never mark "
                            f"(ROS 1 marks them at range_max - 1e-4 when obstacle_range reaches that far)")
        return source

    def parameter_specs(self, params: dict) -> dict[str, Param]:
        specs = super().parameter_specs(params)
        for source in params["sources"]:
            specs.update({f"{source.name}.{key}": spec for key, spec in fields_of(ObservationSourceParams).items()})
        return specs

    def live_params(self, params: dict) -> dict:
        source_specs = fields_of(ObservationSourceParams)
        return {**super().live_params(params),
                "sources": {source.name: {key: getattr(source, key) for key, spec in source_specs.items()
                                          if spec.dynamic} for source in params["sources"]}}

    def parameter_tree(self, params: dict) -> dict:
        tree = super().parameter_tree(params)
        sources = tree.pop("sources")
        tree["observation_sources"] = " ".join(s.name for s in sources)
        for s in sources:
            tree[s.name] = {f.name: getattr(s, f.name) for f in fields(s) if f.name != "name"}
        return tree
