"""Timed elastic band local planner (teb_local_planner), pure numpy/scipy."""

from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.planner import TebLocalPlanner, VelocityCommandResult

__all__ = ["TebConfig", "FootprintModel", "TebLocalPlanner", "VelocityCommandResult"]
