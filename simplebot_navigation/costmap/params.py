"""Costmap parameters from a ROS 1 parameter tree, with Costmap2DROS's semantics (REFERENCE §0.1, §2.2, §2.7).

Input is the nested dict rosparam builds for one costmap (e.g. the value at /move_base/global_costmap);
`parents` are the enclosing namespaces as (path, dict) pairs, nearest first (e.g. ("/move_base", {...})),
for the parameters costmap_2d finds with searchParam (footprint, robot_radius, per-source ranges).
Nothing is logged here: warnings come back as strings for the ROS shell to log.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from .footprint import footprint_from_radius, parse_footprint
from .obstacle_layer import SUPPORTED_DATA_TYPES, ObservationSource
from .plugins import layer_kind

_MISSING = object()

# Costmap-level keys copied (overwriting) into each plugin of a type when `plugins` is given.
_PARENT_KEYS = {
    "StaticLayer": ("map_topic", "unknown_cost_value", "lethal_cost_threshold", "track_unknown_space"),
    "ObstacleLayer": ("max_obstacle_height", "raytrace_range", "obstacle_range", "track_unknown_space"),
    "InflationLayer": ("cost_scaling_factor", "inflation_radius"),
}


@dataclass
class PluginConfig:
    name: str
    type: str
    kind: str                   # ObstacleLayer / InflationLayer / StaticLayer
    params: dict                # keyword arguments of the layer class


@dataclass
class CostmapConfig:
    name: str
    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    rolling_window: bool = False
    track_unknown_space: bool = False
    always_send_full_costmap: bool = False
    transform_tolerance: float = 0.3
    update_frequency: float = 5.0
    publish_frequency: float = 0.0
    width: int = 10
    height: int = 10
    resolution: float = 0.05
    origin_x: float = 0.0
    origin_y: float = 0.0
    footprint: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))   # unpadded
    robot_radius: float = 0.46
    footprint_padding: float = 0.01
    footprint_topic: str = "footprint"
    published_footprint_topic: str = "footprint"
    plugins: list[PluginConfig] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def size_x(self) -> int:
        return int(self.width / self.resolution)

    @property
    def size_y(self) -> int:
        return int(self.height / self.resolution)


class _Namespace:
    """A dict of parameters plus its path, with typed getters that name the key on bad values."""

    def __init__(self, values, path: str):
        if not isinstance(values, dict):
            raise ValueError(f"{path}: expected a namespace (mapping), got {values!r}")
        self.values, self.path = values, path

    def child(self, key: str) -> "_Namespace":
        return _Namespace(self.values.get(key, {}), f"{self.path}/{key}")

    def has(self, key: str) -> bool:
        return key in self.values

    def number(self, key: str, default: float) -> float:
        return _as_number(self.values.get(key, default), f"{self.path}/{key}")

    def integer(self, key: str, default: int) -> int:
        return _as_int(self.values.get(key, default), f"{self.path}/{key}")

    def boolean(self, key: str, default: bool) -> bool:
        value = self.values.get(key, default)
        if not isinstance(value, bool):
            raise ValueError(f"{self.path}/{key}: expected true or false, got {value!r}")
        return value

    def string(self, key: str, default: str) -> str:
        value = self.values.get(key, default)
        if not isinstance(value, str):
            raise ValueError(f"{self.path}/{key}: expected a string, got {value!r}")
        return value

    def frame(self, key: str, default: str) -> str:
        """Frame ids are accepted with a leading '/' and stored without it, as tf2 does."""
        return self.string(key, default).lstrip("/")


def _as_number(value, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        raise ValueError(f"{path}: expected a number, got {value!r}")
    return float(value)


def _as_int(value, path: str) -> int:
    """ROS 1 reads a double into an int parameter by rounding (fraction < .5 down, else up)."""
    number = _as_number(value, path)
    if not math.isfinite(number):
        raise ValueError(f"{path}: expected a finite number, got {value!r}")
    return int(math.floor(number) if math.fmod(number, 1.0) < 0.5 else math.ceil(number))


def _search(chain: list[_Namespace], key: str):
    """searchParam: the value of `key` in the nearest namespace of the chain that has it."""
    for ns in chain:
        if ns.has(key):
            return ns.values[key], f"{ns.path}/{key}"
    return _MISSING, key


def resolve_costmap_params(params: dict, name: str = "costmap", parents=()) -> CostmapConfig:
    """Resolved costmap configuration and per-layer parameters; raises ValueError naming the bad key."""
    tree = copy.deepcopy(params)
    root = _Namespace(tree, name)
    parent_chain = [_Namespace(values, path) for path, values in parents]
    cfg = CostmapConfig(name=name)

    cfg.global_frame = root.frame("global_frame", "map")
    cfg.robot_base_frame = root.frame("robot_base_frame", "base_link")
    cfg.rolling_window = root.boolean("rolling_window", False)
    cfg.track_unknown_space = root.boolean("track_unknown_space", False)
    cfg.always_send_full_costmap = root.boolean("always_send_full_costmap", False)
    cfg.transform_tolerance = root.number("transform_tolerance", 0.3)
    cfg.update_frequency = root.number("update_frequency", 5.0)
    cfg.publish_frequency = root.number("publish_frequency", 0.0)
    cfg.width = root.integer("width", 10)
    cfg.height = root.integer("height", 10)
    cfg.resolution = root.number("resolution", 0.05)
    cfg.origin_x = root.number("origin_x", 0.0)
    cfg.origin_y = root.number("origin_y", 0.0)
    cfg.footprint_padding = root.number("footprint_padding", 0.01)
    for key in ("width", "height"):
        if getattr(cfg, key) < 0:
            raise ValueError(f"{name}/{key}: must be >= 0 metres, got {getattr(cfg, key)}")
    if not cfg.resolution > 0:
        raise ValueError(f"{name}/resolution: must be positive, got {cfg.resolution}")
    for key in ("update_frequency", "publish_frequency", "transform_tolerance"):
        if getattr(cfg, key) < 0:
            raise ValueError(f"{name}/{key}: must be >= 0, got {getattr(cfg, key)}")

    chain = [root] + parent_chain
    cfg.footprint, cfg.robot_radius = _footprint(chain)
    topic, path = _search(chain, "footprint_topic")
    cfg.footprint_topic = "footprint" if topic is _MISSING else _Namespace({"t": topic}, path).string("t", "")
    topic, path = _search(chain, "published_footprint_topic")
    cfg.published_footprint_topic = ("footprint" if topic is _MISSING
                                     else _Namespace({"t": topic}, path).string("t", ""))

    if "plugins" in tree:
        plugin_list = _plugin_list(tree["plugins"], f"{name}/plugins")
        for old in ("static_map", "map_type"):
            if old in tree:
                cfg.warnings.append(f'{name}: Pre-Hydro parameter "{old}" unused since "plugins" is provided')
        for plugin_name, plugin_type, kind in plugin_list:
            target = tree.setdefault(plugin_name, {})
            _Namespace(target, f"{name}/{plugin_name}")
            for key in _PARENT_KEYS[kind]:
                if key in tree:
                    target[key] = copy.deepcopy(tree[key])
        if "observation_sources" in tree:
            cfg.warnings.append(f'{name}: "observation_sources" at the costmap level is not used when "plugins" '
                                f'is provided; list the sources under the obstacle layer\'s namespace')
    else:
        cfg.warnings.append(f'{name}: Parameter "plugins" not provided, loading pre-Hydro parameters')
        plugin_list = _convert_pre_hydro(tree, root)

    for plugin_name, plugin_type, kind in plugin_list:
        ns = root.child(plugin_name)
        if kind == "ObstacleLayer":
            params_ = _obstacle_params(ns, cfg, chain)
            if not params_["sources"]:
                cfg.warnings.append(f"{ns.path}: no observation_sources, so this layer will never see an obstacle")
            for source in params_["sources"]:
                if source.inf_is_valid:
                    cfg.warnings.append(
                        f"{ns.path}/{source.name}: inf_is_valid: +inf ranges clear up to range_max but never mark "
                        f"(ROS 1 marks them at range_max - 1e-4 when obstacle_range reaches that far)")
        elif kind == "InflationLayer":
            params_ = _inflation_params(ns)
        else:
            params_ = _static_params(ns)
        cfg.plugins.append(PluginConfig(plugin_name, plugin_type, kind, params_))
    return cfg


def _footprint(chain):
    value, path = _search(chain, "footprint")
    if value is not _MISSING:
        footprint = parse_footprint(value, path)
        if len(footprint):
            return footprint, 0.46
    value, path = _search(chain, "robot_radius")
    radius = 0.46 if value is _MISSING else _as_number(value, path)
    return footprint_from_radius(radius), radius


def _plugin_list(value, path: str):
    if not isinstance(value, list):
        raise ValueError(f"{path}: expected a list of {{name, type}}, got {value!r}")
    out, names = [], set()
    for i, entry in enumerate(value):
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) \
                or not isinstance(entry.get("type"), str):
            raise ValueError(f"{path}[{i}]: expected {{name: <string>, type: <string>}}, got {entry!r}")
        if entry["name"] in names:
            raise ValueError(f"{path}[{i}]: plugin name {entry['name']!r} is used twice")
        names.add(entry["name"])
        out.append((entry["name"], entry["type"], layer_kind(entry["type"], entry["name"])))
    return out


def _convert_pre_hydro(tree: dict, root: _Namespace):
    """costmap_2d's loadOldParameters: build the plugin list and move the old keys into the layers."""
    def move(target: str, key: str, delete: bool = True):
        if key in tree:
            layer = tree.setdefault(target, {})
            _Namespace(layer, f"{root.path}/{target}")
            layer[key] = tree.pop(key) if delete else copy.deepcopy(tree[key])

    plugins = []
    if root.boolean("static_map", False):
        plugins.append(("static_layer", "costmap_2d::StaticLayer", "StaticLayer"))
        for key in ("map_topic", "unknown_cost_value", "lethal_cost_threshold"):
            move("static_layer", key)
        move("static_layer", "track_unknown_space", delete=False)
    if root.string("map_type", "costmap") == "voxel":
        layer_kind("costmap_2d::VoxelLayer", "obstacle_layer")      # raises: not supported
    plugins.append(("obstacle_layer", "costmap_2d::ObstacleLayer", "ObstacleLayer"))
    for key in ("max_obstacle_height", "raytrace_range", "obstacle_range", "track_unknown_space"):
        move("obstacle_layer", key)
    for source in root.string("observation_sources", "").split():
        move("obstacle_layer", source)
    move("obstacle_layer", "observation_sources")
    for key in ("cost_scaling_factor", "inflation_radius"):
        move("inflation_layer", key)
    plugins.append(("inflation_layer", "costmap_2d::InflationLayer", "InflationLayer"))
    return plugins


def _obstacle_params(ns: _Namespace, cfg: CostmapConfig, chain) -> dict:
    sources = []
    for source_name in ns.string("observation_sources", "").split():
        src = ns.child(source_name)
        data_type = src.string("data_type", "PointCloud")
        if data_type not in SUPPORTED_DATA_TYPES:
            hint = " (the default when data_type is not set)" if not src.has("data_type") else ""
            raise ValueError(f"{src.path}/data_type: {data_type!r}{hint} is not supported; "
                             f"use one of {', '.join(SUPPORTED_DATA_TYPES)}")
        ranges = {}
        for key, default in (("obstacle_range", 2.5), ("raytrace_range", 3.0)):
            value, path = _search([src, ns] + chain, key)
            ranges[key] = default if value is _MISSING else _as_number(value, path)
        sources.append(ObservationSource(
            name=source_name,
            topic=src.string("topic", source_name),
            sensor_frame=src.frame("sensor_frame", ""),
            data_type=data_type,
            marking=src.boolean("marking", True),
            clearing=src.boolean("clearing", False),
            inf_is_valid=src.boolean("inf_is_valid", False),
            expected_update_rate=src.number("expected_update_rate", 0.0),
            observation_persistence=src.number("observation_persistence", 0.0),
            min_obstacle_height=src.number("min_obstacle_height", 0.0),
            max_obstacle_height=src.number("max_obstacle_height", 2.0),
            **ranges))
    combination = ns.integer("combination_method", 1)
    return dict(sources=sources,
                track_unknown_space=ns.boolean("track_unknown_space", cfg.track_unknown_space),
                max_obstacle_height=ns.number("max_obstacle_height", 2.0),
                combination_method=combination,
                footprint_clearing_enabled=ns.boolean("footprint_clearing_enabled", True),
                enabled=ns.boolean("enabled", True))


def _inflation_params(ns: _Namespace) -> dict:
    params = dict(inflation_radius=ns.number("inflation_radius", 0.55),
                  cost_scaling_factor=ns.number("cost_scaling_factor", 10.0),
                  inflate_unknown=ns.boolean("inflate_unknown", False),
                  enabled=ns.boolean("enabled", True))
    if params["inflation_radius"] < 0:
        raise ValueError(f"{ns.path}/inflation_radius: must be >= 0, got {params['inflation_radius']}")
    return params


def _static_params(ns: _Namespace) -> dict:
    return dict(map_topic=ns.string("map_topic", "map"),
                first_map_only=ns.boolean("first_map_only", False),
                subscribe_to_updates=ns.boolean("subscribe_to_updates", False),
                track_unknown_space=ns.boolean("track_unknown_space", True),
                use_maximum=ns.boolean("use_maximum", False),
                lethal_cost_threshold=ns.integer("lethal_cost_threshold", 100),
                unknown_cost_value=ns.integer("unknown_cost_value", -1),
                trinary_costmap=ns.boolean("trinary_costmap", True),
                enabled=ns.boolean("enabled", True))
