"""Each configuration class with the entry point that loads one namespace of it and returns the
warnings the ROS shell would log."""

from simplebot_navigation.costmap.inflation_layer import InflationLayerParams
from simplebot_navigation.costmap.observation import ObservationSourceParams
from simplebot_navigation.costmap.obstacle_layer import ObstacleLayerParams
from simplebot_navigation.costmap.params import CostmapConfig, SearchedParams, resolve_costmap_params
from simplebot_navigation.costmap.static_layer import StaticLayerParams
from simplebot_navigation.move_base.behaviors import BehaviorServerParams
from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.recovery.clear_costmap import ClearCostmapParams, ClearCostmapRecovery
from simplebot_navigation.move_base.recovery.rotate import RotateParams, RotateRecovery
from simplebot_navigation.planning.config import GlobalPlannerConfig, NavfnParams
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel, FootprintModelParams

_LASER = {"observation_sources": "scan", "scan": {"data_type": "LaserScan"}}


def _costmap(given):
    return resolve_costmap_params({"plugins": [], **given}, "c").warnings


def _layer(plugin_type, given):
    return resolve_costmap_params({"plugins": [{"name": "layer", "type": plugin_type}], "layer": given},
                                  "c").warnings


def _source(given):
    scan = {"data_type": "LaserScan", **given}
    return _layer("costmap_2d::ObstacleLayer", {"observation_sources": "scan", "scan": scan})


LOADERS = {
    TebConfig: lambda given: TebConfig.from_params(given).warnings,
    FootprintModelParams: lambda given: FootprintModel.from_params(given).warnings,
    GlobalPlannerConfig: lambda given: list(GlobalPlannerConfig.from_params(given).warnings),
    NavfnParams: lambda given: list(GlobalPlannerConfig.from_navfn_params(given).warnings),
    MoveBaseConfig: lambda given: MoveBaseConfig.from_params(given).warnings,
    BehaviorServerParams: lambda given: BehaviorServerParams.from_params(given).warnings,
    ClearCostmapParams: lambda given: ClearCostmapRecovery("reset", given, {}, lambda *a: [], 1.0).warnings,
    RotateParams: lambda given: RotateRecovery("rotate", given, lambda poses: True).warnings,
    CostmapConfig: _costmap,
    SearchedParams: _costmap,
    ObstacleLayerParams: lambda given: _layer("costmap_2d::ObstacleLayer", {**_LASER, **given}),
    InflationLayerParams: lambda given: _layer("costmap_2d::InflationLayer", given),
    StaticLayerParams: lambda given: _layer("costmap_2d::StaticLayer", given),
    ObservationSourceParams: _source,
}

#: keys whose default draws a deliberate warning or error: pre-Hydro keys next to a plugin list, an
#: obstacle layer without sources, the unsupported PointCloud default
DELIBERATE = {CostmapConfig: ("static_map", "map_type", "observation_sources"),
              ObstacleLayerParams: ("observation_sources",), ObservationSourceParams: ("data_type",)}
