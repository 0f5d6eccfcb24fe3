"""global_planner/GlobalPlanner and navfn/NavfnROS as move_base plugins: their registrations (named by
pyproject.toml's ``simplebot_navigation.global_planners`` entry points). The ROS wrapper both run in is
named as text, so that this module imports no rclpy."""

from __future__ import annotations

from simplebot_navigation.planning.config import GLOBAL_PLANNER, NAVFN, GlobalPlannerConfig, NavfnParams
from simplebot_navigation.pluginlib import PluginSpec

_ROS_WRAPPER = "simplebot_navigation.ros.move_base.global_planner_ros:GlobalPlannerROS"


def global_planner_config(given):
    config = GlobalPlannerConfig.from_params(given)
    return config, config.warnings


def navfn_config(given):
    config = GlobalPlannerConfig.from_navfn_params(given)
    return config, config.warnings


GLOBAL_PLANNER_SPEC = PluginSpec(GLOBAL_PLANNER, _ROS_WRAPPER, GlobalPlannerConfig, global_planner_config)
NAVFN_SPEC = PluginSpec(NAVFN, _ROS_WRAPPER, NavfnParams, navfn_config)
