"""An example global planner: a straight line from start to goal, refused when it crosses a lethal cell.

Its ROS wrapper is the whole plugin (a planner this small needs no pure core of its own). One module, and its
registration ``SPEC``, which a test or an application registers with ``GLOBAL_PLANNERS.register(SPEC)`` before
move_base starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.move_base.plugins import plugin_namespace
from simplebot_navigation.parameters import build, fields_of, param
from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree


@dataclass
class StraightLineParams:
    spacing: float = param(0.05, "m", "distance between the poses of a plan", gt=0)


def straight_line_config(given):
    return build(StraightLineParams, given, "move_base/StraightLinePlanner")


@dataclass
class StraightPlan:
    ok: bool
    poses: np.ndarray
    message: str = ""


class StraightLinePlanner:
    def __init__(self, node, plugin_type: str, costmap_ros):
        self.name = plugin_namespace(plugin_type)
        self.costmap_ros = costmap_ros
        self.config, warnings = straight_line_config(given_parameter_tree(node, self.name))
        declare_defaults(node, {"spacing": self.config.spacing}, prefix=self.name,
                         specs=fields_of(StraightLineParams))

    def reconfigure(self, config: StraightLineParams) -> None:
        self.config = config

    def make_plan(self, start, goal, tolerance=None) -> StraightPlan:
        length = math.hypot(goal[0] - start[0], goal[1] - start[1])
        steps = max(1, math.ceil(length / self.config.spacing))
        t = np.linspace(0.0, 1.0, steps + 1)
        heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
        poses = np.column_stack([start[0] + t * (goal[0] - start[0]), start[1] + t * (goal[1] - start[1]),
                                 np.full(len(t), heading)])
        poses[-1, 2] = goal[2]
        if self.blocked_poses(poses, start).any():
            return StraightPlan(False, np.empty((0, 3)), "the straight line crosses an obstacle")
        return StraightPlan(True, poses)

    def blocked_poses(self, poses: np.ndarray, robot_pose) -> np.ndarray:
        with self.costmap_ros.lock:
            master = self.costmap_ros.costmap
            blocked = np.zeros(len(poses), dtype=bool)
            for i, (x, y, _) in enumerate(poses):
                cell = master.world_to_map(x, y)
                blocked[i] = cell is not None and master.get_cost(*cell) == LETHAL_OBSTACLE
        return blocked


SPEC = PluginSpec("example/StraightLinePlanner", StraightLinePlanner, StraightLineParams, straight_line_config)
