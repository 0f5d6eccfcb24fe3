"""An example local planner: pure pursuit of the global plan at a fixed speed (it ignores obstacles).

One module, and its registration ``SPEC``, which a test or an application registers with
``LOCAL_PLANNERS.register(SPEC)`` before move_base starts. The module is its own ROS wrapper, so the
registration names the class itself; a registration that must import without rclpy names its wrapper as
"module:attribute" text instead (teb/plugin.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.move_base.plugins import ControlResult, plugin_namespace
from simplebot_navigation.parameters import build, fields_of, param
from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree


@dataclass
class PurePursuitParams:
    speed: float = param(0.3, "m/s", "forward speed", gt=0, le=1.0)
    lookahead: float = param(0.4, "m", "distance to the point of the plan steered at", gt=0)
    xy_goal_tolerance: float = param(0.15, "m", "the goal counts as reached this close", gt=0)


def pure_pursuit_config(given):
    return build(PurePursuitParams, given, "move_base/PurePursuit")


class PurePursuit:
    def __init__(self, node, plugin_type, costmap_ros, tf_buffer, controller_frequency: float, plan_frame: str,
                 obstacle_feed):
        self.name = plugin_namespace(plugin_type)
        self.costmap_ros = costmap_ros
        self.plan_frame = plan_frame
        self.config, _ = pure_pursuit_config(given_parameter_tree(node, self.name))
        declare_defaults(node, {f: getattr(self.config, f) for f in fields_of(PurePursuitParams)}, prefix=self.name,
                         specs=fields_of(PurePursuitParams))
        self.plan = np.empty((0, 3))
        self.pose = None

    # -- the Controller ---------------------------------------------------------------------------
    def set_plan(self, plan: np.ndarray) -> bool:
        if self.plan_frame.lstrip("/") != self.costmap_ros.global_frame.lstrip("/"):
            return False          # this example steers in the global costmap's frame only
        self.plan = np.asarray(plan, dtype=float)
        return True

    def begin_cycle(self, pose) -> None:
        self.pose = pose

    def compute(self) -> ControlResult:
        pose = self.pose
        if pose is None or not len(self.plan):
            return ControlResult(False, message="no pose or no plan")
        x, y, yaw = pose[:3]
        distance = np.hypot(self.plan[:, 0] - x, self.plan[:, 1] - y)
        rest = distance[int(np.argmin(distance)):]              # the plan from the nearest pose on
        ahead = np.flatnonzero(rest >= self.config.lookahead)
        tx, ty = self.plan[len(distance) - len(rest) + ahead[0], :2] if len(ahead) else self.plan[-1, :2]
        error = float(normalize_theta(math.atan2(ty - y, tx - x) - yaw))
        return ControlResult(True, self.config.speed * max(0.0, math.cos(error)), 1.5 * error)

    def is_goal_reached(self) -> bool:
        pose = self.pose
        return (pose is not None and len(self.plan) > 0
                and math.hypot(self.plan[-1, 0] - pose[0], self.plan[-1, 1] - pose[1]) <= self.config.xy_goal_tolerance)

    def reset(self) -> None:
        self.plan = np.empty((0, 3))

    # -- live parameters -----------------------------------------------------------------------------
    def reconfigure(self, config: PurePursuitParams) -> None:
        self.config = config

    def set_controller_frequency(self, controller_frequency: float) -> None:
        pass                      # it keeps nothing that depends on the period

    def set_costmap_footprint(self, footprint) -> None:
        pass                      # it does not look at obstacles


SPEC = PluginSpec("example/PurePursuit", PurePursuit, PurePursuitParams, pure_pursuit_config)
