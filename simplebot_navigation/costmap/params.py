"""Costmap parameters from a ROS 1 parameter tree, with Costmap2DROS's semantics (docs/reference.md §0.1, §2.2, §2.7).

Input is the nested dict rosparam builds for one costmap (e.g. the value at /move_base/global_costmap);
`parents` are the enclosing namespaces as (path, dict) pairs, nearest first (e.g. ("/move_base", {...})),
for the parameters costmap_2d finds with searchParam (footprint, robot_radius, per-source ranges).
Every namespace (costmap, layer, observation source) is declared and checked with the parameter layer.
Nothing is logged here: warnings come back as strings for the ROS shell to log.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from simplebot_navigation.parameters import Param, ParameterError, fields_of, load, namespace, param
from simplebot_navigation.costmap.footprint import footprint_from_radius, parse_footprint
from simplebot_navigation.costmap.plugins import LAYERS, LayerContext


@dataclass
class PluginConfig:
    name: str
    type: str
    kind: str                   # the registered layer kind (StaticLayer, ObstacleLayer, ...)
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


def searched_keys() -> tuple[str, ...]:
    """Keys the costmap reads from enclosing namespaces too: SearchedParams and those its layers search
    upwards (an obstacle layer's sources: their ranges)."""
    layers = (key for spec in LAYERS.specs for key in spec.searched_keys)
    return tuple(fields_of(SearchedParams)) + tuple(dict.fromkeys(layers))


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
    """The parameters of a layer that may change while it runs, as the layer's ``reconfigure`` takes them
    (its registration's ``live_params``)."""
    return LAYERS.spec(plugin.kind).live_params(plugin.params)


def parameter_specs(cfg: CostmapConfig) -> dict[str, Param]:
    """Every parameter of a resolved costmap by ROS 2 name below the costmap (``obstacles.front_laser.topic``)."""
    specs = {**fields_of(CostmapConfig), **fields_of(SearchedParams), "plugins": PLUGIN_LIST}
    for plugin in cfg.plugins:
        layer = LAYERS.spec(plugin.kind)
        own = layer.keys()
        for key in layer.parent_keys:           # set at the costmap level, copied into the layer
            specs.setdefault(key, own[key])
        specs.update({f"{plugin.name}.{key}": spec for key, spec in layer.parameter_specs(plugin.params).items()})
    return specs


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
                            also_known=list(searched_keys()) + sorted(parent_keys) + namespaces)
    values.pop("plugins", None)
    cfg = CostmapConfig(name=name, **values)
    cfg.global_frame = cfg.global_frame.lstrip("/")          # tf2 frame ids have no leading '/'
    cfg.robot_base_frame = cfg.robot_base_frame.lstrip("/")

    context = LayerContext(cfg, chain)
    searched = fields_of(SearchedParams)
    footprint = context.searched("footprint", searched["footprint"])
    cfg.footprint = parse_footprint(footprint, context.search("footprint")[1])
    if len(cfg.footprint):
        cfg.robot_radius = searched["robot_radius"].default
    else:
        cfg.robot_radius = context.searched("robot_radius", searched["robot_radius"])
        cfg.footprint = footprint_from_radius(cfg.robot_radius)
    cfg.footprint_topic = context.searched("footprint_topic", searched["footprint_topic"])
    cfg.published_footprint_topic = context.searched("published_footprint_topic",
                                                     searched["published_footprint_topic"])

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
        layer_params, layer_warnings = LAYERS.spec(kind).resolve(layer_tree, path, context)
        warnings += layer_warnings
        cfg.plugins.append(PluginConfig(plugin_name, plugin_type, kind, layer_params))
    cfg.warnings = warnings
    return cfg


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
