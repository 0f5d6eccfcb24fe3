"""Every parameter of a move_base node, by its ROS 2 name, from the node's ROS 1 tree.

Which namespaces exist depends on the tree itself (the selected planners, each costmap's plugin
list and observation sources, the recovery list), so the table is built from it. ``build_configs``
builds every configuration the node would build at start-up (``check_tree``: its warnings); overrides
(``--set``) and run-time changes go through both (simplebot_navigation.parameters.overrides), and a
running node takes the configurations of a change (move_base/live_parameters.py).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from simplebot_navigation.costmap.params import CostmapConfig, SearchedParams, parameter_specs, resolve_costmap_params
from simplebot_navigation.parameters import PLUGIN_TYPE_KEY, Param, build, fields_of
from simplebot_navigation.parameters.overrides import ParameterTable, apply_overrides
from simplebot_navigation.perception import TrackerParams
from simplebot_navigation.teb.footprint import FootprintModelParams
from simplebot_navigation.move_base.behaviors import BehaviorServerParams
from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.plugins import GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS, plugin_namespace

COSTMAPS = ("global_costmap", "local_costmap")
#: move_base's namespace of the moving-obstacle tracker (docs/reference.md §6)
OBSTACLE_TRACKING = "obstacle_tracking"
#: move_base's namespace of Nav2 behavior_server's parameters, the limits of Nav2's behaviours (docs/reference.md §9.3)
BEHAVIOR_SERVER = "behavior_server"


def crowd_planner(cfg: MoveBaseConfig) -> str | None:
    """The type of the planner that drives while moving obstacles are near, when it is not the base planner."""
    crowd = cfg.crowd_local_planner
    return crowd if crowd and crowd != cfg.base_local_planner else None


def planner_types(cfg: MoveBaseConfig) -> list[tuple]:
    """(registry, type) of every planner plugin the node builds: the global, the local and the crowd planner."""
    types = [(GLOBAL_PLANNERS, cfg.base_global_planner), (LOCAL_PLANNERS, cfg.base_local_planner)]
    return types + ([(LOCAL_PLANNERS, crowd_planner(cfg))] if crowd_planner(cfg) else [])


def _prefixed(prefix: str, cls) -> ParameterTable:
    return {f"{prefix}{name}": spec for name, spec in fields_of(cls).items()}


def parameter_table(tree: dict) -> ParameterTable:
    """Every parameter the move_base node with this ROS 1 tree reads, by ROS 2 name."""
    table = {**fields_of(MoveBaseConfig), **fields_of(SearchedParams),
             **_prefixed(f"{OBSTACLE_TRACKING}.", TrackerParams),
             **_prefixed(f"{BEHAVIOR_SERVER}.", BehaviorServerParams)}
    cfg = MoveBaseConfig.from_params(tree)
    for registry, plugin_type in planner_types(cfg):
        params = registry.spec(plugin_type).params
        if params is not None:
            table.update(_prefixed(f"{plugin_namespace(plugin_type)}.", params))
    for behavior in cfg.recovery_behaviors:
        params = RECOVERY_BEHAVIORS.spec(behavior["type"]).params
        if params is not None:
            table.update(_prefixed(f"{behavior['name']}.", params))
    for name in COSTMAPS:
        costmap = resolve_costmap_params(tree.get(name, {}), name, [("move_base", tree)])
        table.update({f"{name}.{key}": spec for key, spec in parameter_specs(costmap).items()})
    return table


def live_parameter_table(tree: dict) -> ParameterTable:
    """parameter_table plus what a running node declares beyond it, all restart-only: each plugin's type
    (``local_costmap.obstacles.plugin``) and the keys of TEB's footprint model."""
    table = parameter_table(tree)
    for name in COSTMAPS:
        for plugin in resolve_costmap_params(tree.get(name, {}), name, [("move_base", tree)]).plugins:
            table[f"{name}.{plugin.name}.{PLUGIN_TYPE_KEY}"] = _plugin_type(f"layer {plugin.name}")
    for behavior in MoveBaseConfig.from_params(tree).recovery_behaviors:
        table[f"{behavior['name']}.{PLUGIN_TYPE_KEY}"] = _plugin_type(f"recovery behaviour {behavior['name']}")
    if "TebLocalPlannerROS.footprint_model" in table:
        table.update({f"TebLocalPlannerROS.footprint_model.{key}": dataclasses.replace(spec, dynamic=False)
                      for key, spec in fields_of(FootprintModelParams).items()})
    return table


def _plugin_type(what: str) -> Param:
    return Param(str, "", "", f"plugin type of {what}", dynamic=False, name=PLUGIN_TYPE_KEY)


@dataclass
class NodeConfigs:
    """Every configuration a move_base node builds from its tree, and the warnings it would log."""
    move_base: MoveBaseConfig
    costmaps: dict[str, CostmapConfig]
    global_planner: object | None          # its registration's config (None: a planner without parameters)
    local_planner: object | None
    crowd_planner: object | None           # the crowd planner's config (None: none, or one without parameters)
    recoveries: dict[str, dict] = field(default_factory=dict)   # behaviour name -> its (checked) namespace
    warnings: list[str] = field(default_factory=list)
    obstacle_tracking: TrackerParams = field(default_factory=TrackerParams)
    behavior_server: BehaviorServerParams = field(default_factory=BehaviorServerParams)


def build_configs(tree: dict) -> NodeConfigs:
    """Build every configuration of the node from the tree, raising ParameterError on a bad value."""
    cfg = MoveBaseConfig.from_params(tree)
    warnings = list(cfg.warnings)
    costmaps = {}
    for name in COSTMAPS:
        costmaps[name] = resolve_costmap_params(tree.get(name, {}), name, [("move_base", tree)])
        warnings += costmaps[name].warnings
    planners = []
    for registry, plugin_type in planner_types(cfg):
        spec = registry.spec(plugin_type)
        planner, planner_warnings = (None, []) if spec.config is None else spec.config(
            tree.get(plugin_namespace(plugin_type)))
        planners.append(planner)
        warnings += planner_warnings
    recoveries = {}
    for behavior in cfg.recovery_behaviors:
        given = tree.get(behavior["name"])
        params = RECOVERY_BEHAVIORS.spec(behavior["type"]).params
        if params is not None:
            warnings += build(params, given, f"move_base/{behavior['name']}", also_known=[PLUGIN_TYPE_KEY])[1]
        recoveries[behavior["name"]] = dict(given) if isinstance(given, dict) else {}
    tracking = TrackerParams.from_params(tree.get(OBSTACLE_TRACKING, {}), f"move_base/{OBSTACLE_TRACKING}")
    behavior_server = BehaviorServerParams.from_params(tree.get(BEHAVIOR_SERVER, {}), f"move_base/{BEHAVIOR_SERVER}")
    planners += [None] * (3 - len(planners))
    return NodeConfigs(cfg, costmaps, *planners, recoveries, warnings + tracking.warnings + behavior_server.warnings,
                       tracking, behavior_server)


def check_tree(tree: dict) -> list[str]:
    """Build every configuration of the node from the tree (raising ParameterError on a bad value) and
    return the warnings the node would log."""
    return build_configs(tree).warnings


def apply_move_base_overrides(tree: dict, assignments, live: bool = False) -> tuple[dict, list[str]]:
    """``--set`` for move_base (``live``: a change while running, which refuses restart-only parameters and
    those without effect): the new tree and the warnings the node would log with it."""
    return apply_overrides(tree, assignments, live_parameter_table if live else parameter_table, check_tree,
                           live=live)
