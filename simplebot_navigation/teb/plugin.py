"""teb_local_planner/TebLocalPlannerROS as a move_base plugin: its registration (named by pyproject.toml's
``simplebot_navigation.local_planners`` entry point). The ROS wrapper is named as text, so that this module
imports no rclpy."""

from __future__ import annotations

from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel

TEB_LOCAL_PLANNER = "teb_local_planner/TebLocalPlannerROS"


def teb_config(given):
    config = TebConfig.from_params(given)
    return config, config.warnings + FootprintModel.from_params(config.footprint_model).warnings


SPEC = PluginSpec(TEB_LOCAL_PLANNER, "simplebot_navigation.ros.move_base.teb_local_planner_ros:TebLocalPlannerROS",
                  TebConfig, teb_config)
