"""Costmap parameters from a ROS 1 parameter tree, with Costmap2DROS's semantics (docs/reference.md §0.1, §2.2, §2.7).

Input is the nested dict rosparam builds for one costmap (e.g. the value at /move_base/global_costmap);
`parents` are the enclosing namespaces as (path, dict) pairs, nearest first (e.g. ("/move_base", {...})),
for the parameters costmap_2d finds with searchParam (footprint, robot_radius, per-source ranges).
Every namespace (costmap, layer, observation source) is declared and checked with the parameter layer.
Nothing is logged here: warnings come back as strings for the ROS shell to log.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from simplebot_navigation.parameters import PLUGIN_TYPE_KEY, Param, ParameterError, fields_of, load, namespace, param
from simplebot_navigation.costmap.footprint import footprint_from_radius, parse_footprint
from simplebot_navigation.costmap.obstacle_layer import (SUPPORTED_DATA_TYPES, ObservationSource,
                                                         ObservationSourceParams, ObstacleLayerParams)
from simplebot_navigation.costmap.plugins import LAYERS

_MISSING = object()

_PRE_HYDRO_KEYS = ("static_map", "map_type", "observation_sources")


@dataclass
class PluginConfig:
    name: str
    type: str
    kind: str                   # ObstacleLayer / InflationLayer / StaticLayer
    params: dict                # keyword arguments of the layer class


@dataclass
class SearchedParams:
    """Found with searchParam: in the costmap's namespace or the nearest parent that has them."""
    footprint: list = param([], "m", "robot outline [[x, y], ...] in the base frame (or its string form); "
                            "empty: a circle of robot_radius", kind=(list, str))
    robot_radius: float = param(0.46, "m", "radius of a round robot, used when footprint is empty", ge=0)
    footprint_topic: str = param("footprint", "", "topic a new footprint (Polygon) arrives on", restart=True)
    published_footprint_topic: str = param("footprint", "", "topic the padded footprint is published on",
                                           restart=True)


#: keys the costmap reads from enclosing namespaces too (see SearchedParams, ObservationSourceParams)
SEARCHED_KEYS = tuple(fields_of(SearchedParams)) + ("obstacle_range", "raytrace_range")

PLUGIN_LIST = Param(list, [], "", "layers in order, as a list of {name, type}", dynamic=False, name="plugins")


@dataclass
class CostmapConfig:
    name: str
    global_frame: str = param("map", "", "frame the costmap is kept in", restart=True)
    robot_base_frame: str = param("base_link", "", "the robot's base frame", restart=True)
    rolling_window: bool = param(False, "", "keep the map centred on the robot", restart=True)
    track_unknown_space: bool = param(False, "", "the master grid starts unknown instead of free", restart=True)
    always_send_full_costmap: bool = param(False, "", "publish the whole grid on every publish cycle")
    transform_tolerance: float = param(0.3, "s", "tolerated age of the robot pose transform", ge=0)
    update_frequency: float = param(5.0, "Hz", "map update rate (0: never)", ge=0, le=100.0)
    publish_frequency: float = param(0.0, "Hz", "map publish rate (0: never)", ge=0, le=100.0)
    width: int = param(10, "m", "map width (an int, rounded like ROS 1)", ge=0, rounds=True, restart=True)
    height: int = param(10, "m", "map height (an int, rounded like ROS 1)", ge=0, rounds=True, restart=True)
    resolution: float = param(0.05, "m/cell", "cell size", gt=0, restart=True)
    origin_x: float = param(0.0, "m", "x of the map's lower left corner in global_frame", restart=True)
    origin_y: float = param(0.0, "m", "y of the map's lower left corner in global_frame", restart=True)
    footprint_padding: float = param(0.01, "m", "added around the footprint")
    static_map: bool = param(False, "", "pre-Hydro: add a static layer (used only without plugins)", restart=True)
    map_type: str = param("costmap", "", "pre-Hydro: costmap or voxel (used only without plugins)", restart=True)
    observation_sources: str = param("", "", "pre-Hydro: sensor sub-namespaces (used only without plugins)",
                                     restart=True)
    # resolved from searchParam (SearchedParams) and the plugin list
    footprint: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))   # unpadded
    robot_radius: float = 0.46
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




def live_layer_params(plugin: PluginConfig) -> dict:
    """The parameters of a layer that may change while it runs (not restart-only in their spec), as the
    layer's ``reconfigure`` takes them; an obstacle layer's sources come as {source name: {field: value}}."""
    specs = fields_of(LAYERS.spec(plugin.kind).params)
    live = {key: value for key, value in plugin.params.items() if key in specs and specs[key].dynamic}
    if plugin.kind == "ObstacleLayer":
        source_specs = fields_of(ObservationSourceParams)
        live["sources"] = {source.name: {key: getattr(source, key) for key, spec in source_specs.items()
                                         if spec.dynamic} for source in plugin.params["sources"]}
    return live


def parameter_specs(cfg: CostmapConfig) -> dict[str, Param]:
    """Every parameter of a resolved costmap by ROS 2 name below the costmap (``obstacles.front_laser.topic``)."""
    specs = {**fields_of(CostmapConfig), **fields_of(SearchedParams), "plugins": PLUGIN_LIST}
    for plugin in cfg.plugins:
        layer = LAYERS.spec(plugin.kind)
        own = {**fields_of(ObservationSourceParams), **fields_of(layer.params)}
        for key in layer.parent_keys:           # set at the costmap level, copied into the layer
            specs.setdefault(key, own[key])
        specs.update({f"{plugin.name}.{key}": spec for key, spec in fields_of(layer.params).items()})
        for source in plugin.params.get("sources", ()):
            specs.update({f"{plugin.name}.{source.name}.{key}": spec
                          for key, spec in fields_of(ObservationSourceParams).items()})
    return specs


def _search(chain: list[tuple[dict, str]], key: str):
    """searchParam: the value of `key` in the nearest namespace of the chain that has it."""
    for values, path in chain:
        if key in values:
            return values[key], f"{path}/{key}"
    return _MISSING, key


def _searched(chain, specs: dict[str, Param], key: str):
    value, path = _search(chain, key)
    return specs[key].default if value is _MISSING else specs[key].check(value, path)


def resolve_costmap_params(params: dict, name: str = "costmap", parents=()) -> CostmapConfig:
    """Resolved costmap configuration and per-layer parameters; raises ParameterError naming the bad key."""
    tree = copy.deepcopy(namespace(params, name))
    chain = [(tree, name)] + [(namespace(values, path), path) for path, values in parents]
    plugins_given = "plugins" in tree
    sources = tree.get("observation_sources", "")
    source_names = sources.split() if isinstance(sources, str) else []
    if plugins_given:
        plugin_list = _plugin_list(tree["plugins"], f"{name}/plugins")
        namespaces = [plugin_name for plugin_name, _, _ in plugin_list] + source_names
    else:
        namespaces = ["static_layer", "obstacle_layer", "inflation_layer"] + source_names
    parent_keys = {key for spec in LAYERS.specs for key in spec.parent_keys}
    values, warnings = load({**fields_of(CostmapConfig), "plugins": PLUGIN_LIST}, tree, name,
                            also_known=list(SEARCHED_KEYS) + sorted(parent_keys) + namespaces)
    values.pop("plugins", None)
    cfg = CostmapConfig(name=name, **values)
    cfg.global_frame = cfg.global_frame.lstrip("/")          # tf2 frame ids have no leading '/'
    cfg.robot_base_frame = cfg.robot_base_frame.lstrip("/")

    searched = fields_of(SearchedParams)
    footprint = _searched(chain, searched, "footprint")
    cfg.footprint = parse_footprint(footprint, _search(chain, "footprint")[1])
    if len(cfg.footprint):
        cfg.robot_radius = searched["robot_radius"].default
    else:
        cfg.robot_radius = _searched(chain, searched, "robot_radius")
        cfg.footprint = footprint_from_radius(cfg.robot_radius)
    cfg.footprint_topic = _searched(chain, searched, "footprint_topic")
    cfg.published_footprint_topic = _searched(chain, searched, "published_footprint_topic")

    if plugins_given:
        for old in ("static_map", "map_type"):
            if old in tree:
                warnings.append(f'{name}: Pre-Hydro parameter "{old}" unused since "plugins" is provided')
        for plugin_name, plugin_type, kind in plugin_list:
            target = namespace(tree.setdefault(plugin_name, {}), f"{name}/{plugin_name}")
            for key in LAYERS.spec(kind).parent_keys:
                if key in tree:
                    target[key] = copy.deepcopy(tree[key])
        if "observation_sources" in tree:
            warnings.append(f'{name}: "observation_sources" at the costmap level is not used when "plugins" '
                            f'is provided; list the sources under the obstacle layer\'s namespace')
    else:
        warnings.append(f'{name}: Parameter "plugins" not provided, loading pre-Hydro parameters')
        plugin_list = _convert_pre_hydro(tree, cfg)

    for plugin_name, plugin_type, kind in plugin_list:
        path = f"{name}/{plugin_name}"
        layer_tree = namespace(tree.get(plugin_name, {}), path)
        if kind == "ObstacleLayer":
            params_ = _obstacle_params(layer_tree, path, cfg, chain, warnings)
        else:
            layer_params = LAYERS.spec(kind).params
            layer, layer_warnings = load(fields_of(layer_params), layer_tree, path, also_known=[PLUGIN_TYPE_KEY])
            warnings += layer_warnings
            params_ = {**_defaults(layer_params), **layer}
        if kind == "InflationLayer":
            _check_inflation_radius(params_["inflation_radius"], cfg, path)
        cfg.plugins.append(PluginConfig(plugin_name, plugin_type, kind, params_))
    cfg.warnings = warnings
    return cfg


def _defaults(cls) -> dict:
    return {key: spec.default for key, spec in fields_of(cls).items()}


def _plugin_list(value, path: str):
    if not isinstance(value, list):
        raise ParameterError(f"{path}: expected a list of {{name, type}}, got {value!r}")
    out, names = [], set()
    for i, entry in enumerate(value):
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) \
                or not isinstance(entry.get("type"), str):
            raise ParameterError(f"{path}[{i}]: expected {{name: <string>, type: <string>}}, got {entry!r}")
        if entry["name"] in names:
            raise ParameterError(f"{path}[{i}]: plugin name {entry['name']!r} is used twice")
        names.add(entry["name"])
        out.append((entry["name"], entry["type"], LAYERS.kind(entry["type"], entry["name"])))
    return out


def _convert_pre_hydro(tree: dict, cfg: CostmapConfig):
    """costmap_2d's loadOldParameters: build the plugin list and move the old keys into the layers."""
    def move(target: str, key: str, delete: bool = True):
        if key in tree:
            layer = namespace(tree.setdefault(target, {}), f"{cfg.name}/{target}")
            layer[key] = tree.pop(key) if delete else copy.deepcopy(tree[key])

    plugins = []
    if cfg.static_map:
        plugins.append(("static_layer", "costmap_2d::StaticLayer", "StaticLayer"))
        for key in ("map_topic", "unknown_cost_value", "lethal_cost_threshold"):
            move("static_layer", key)
        move("static_layer", "track_unknown_space", delete=False)
    if cfg.map_type == "voxel":
        LAYERS.kind("costmap_2d::VoxelLayer", "obstacle_layer")      # raises: not supported
    plugins.append(("obstacle_layer", "costmap_2d::ObstacleLayer", "ObstacleLayer"))
    for key in ("max_obstacle_height", "raytrace_range", "obstacle_range", "track_unknown_space"):
        move("obstacle_layer", key)
    for source in cfg.observation_sources.split():
        move("obstacle_layer", source)
    move("obstacle_layer", "observation_sources")
    for key in ("cost_scaling_factor", "inflation_radius"):
        move("inflation_layer", key)
    plugins.append(("inflation_layer", "costmap_2d::InflationLayer", "InflationLayer"))
    return plugins


def _check_inflation_radius(radius: float, cfg: CostmapConfig, path: str) -> None:
    """Inflation reaches at most across the whole map: a larger radius only costs memory and time (its kernel
    grows with the square of it), which can stall the costmap's thread for seconds."""
    diagonal = math.hypot(cfg.width, cfg.height)
    if radius > diagonal:
        raise ParameterError(f"{path}/inflation_radius: {radius:g} m is more than the costmap's diagonal "
                             f"({diagonal:.3g} m for {cfg.width:g} x {cfg.height:g} m)")


def _obstacle_params(layer_tree: dict, path: str, cfg: CostmapConfig, chain, warnings: list) -> dict:
    names = layer_tree.get("observation_sources", "")
    names = names.split() if isinstance(names, str) else []
    layer, layer_warnings = load(fields_of(ObstacleLayerParams), layer_tree, path,
                                 also_known=[PLUGIN_TYPE_KEY, "obstacle_range", "raytrace_range"] + names)
    warnings += layer_warnings
    params = {**_defaults(ObstacleLayerParams), "track_unknown_space": cfg.track_unknown_space, **layer}
    source_specs = fields_of(ObservationSourceParams)
    sources = []
    for source_name in params.pop("observation_sources").split():
        src_path = f"{path}/{source_name}"
        src_tree = namespace(layer_tree.get(source_name, {}), src_path)
        given, source_warnings = load(source_specs, src_tree, src_path)
        warnings += source_warnings
        src = {**_defaults(ObservationSourceParams), **given}
        if src["data_type"] not in SUPPORTED_DATA_TYPES:
            hint = " (the default when data_type is not set)" if "data_type" not in src_tree else ""
            raise ParameterError(f"{src_path}/data_type: {src['data_type']!r}{hint} is not supported; "
                                 f"use one of {', '.join(SUPPORTED_DATA_TYPES)}")
        for key in ("obstacle_range", "raytrace_range"):
            src[key] = _searched([(src_tree, src_path), (layer_tree, path)] + chain, source_specs, key)
        src["sensor_frame"] = src["sensor_frame"].lstrip("/")
        source = ObservationSource(name=source_name, **src)
        if source.inf_is_valid:
            warnings.append(f"{src_path}: inf_is_valid: +inf ranges clear up to range_max but never mark "
                            f"(ROS 1 marks them at range_max - 1e-4 when obstacle_range reaches that far)")
        sources.append(source)
    if not sources:
        warnings.append(f"{path}: no observation_sources, so this layer will never see an obstacle")
    return {**params, "sources": sources}
