"""rotate_recovery/RotateRecovery: a full turn in place, as ROS 1's."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.parameters import param
from simplebot_navigation.move_base.recovery import ParameterisedRecovery, RecoveryContext, RecoveryStep, turn_rate

ROTATE_RECOVERY = "rotate_recovery/RotateRecovery"

#: read from the (ROS 1 default) local planner's namespace when the behaviour's own has none
BORROWED = ("acc_lim_theta", "max_vel_theta", "min_in_place_vel_theta", "yaw_goal_tolerance")

@dataclass
class RotateParams:
    """The ``<name>/`` namespace of a rotate_recovery/RotateRecovery (the speed limits are also read from
    TrajectoryPlannerROS, as ROS 1 does)."""
    sim_granularity: float = param(0.017, "rad", "turn between two collision checks", gt=0)
    acc_lim_theta: float = param(3.2, "rad/s^2", "angular acceleration limit", gt=0)
    max_vel_theta: float = param(1.0, "rad/s", "maximum turn rate", gt=0)
    min_in_place_vel_theta: float = param(0.4, "rad/s", "minimum turn rate", ge=0)
    yaw_goal_tolerance: float = param(0.10, "rad", "turn left over when the circle counts as done", ge=0)


class RotateRecovery(ParameterisedRecovery):
    """Turn a full circle in place (counter-clockwise) to let the sensors see everything around.

    footprint_clear(poses) says per (x, y, yaw) row whether the footprint is collision free on the
    local costmap; the remaining turn is checked every sim_granularity before each step, as ROS 1 does.
    """

    PARAMS = RotateParams

    def __init__(self, name: str, params: dict, footprint_clear: Callable[[np.ndarray], np.ndarray]):
        self.name = name
        self._clear = footprint_clear
        self._start_yaw = 0.0
        self._turned = 0.0
        self._last_yaw = 0.0
        self.warnings = self.configure(params)

    def start(self, now: float, pose) -> None:
        self._start_yaw = self._last_yaw = pose[2]
        self._turned = 0.0

    def tick(self, now: float, pose) -> RecoveryStep:
        x, y, yaw = pose
        self._turned += float(normalize_theta(yaw - self._last_yaw))
        self._last_yaw = yaw
        dist_left = 2.0 * math.pi - self._turned
        if dist_left < self.yaw_goal_tolerance:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: turned a full circle")
        yaws = yaw + np.linspace(0.0, dist_left, max(1, int(dist_left / self.sim_granularity)) + 1)
        if not np.all(self._clear(np.column_stack([np.full_like(yaws, x), np.full_like(yaws, y), yaws]))):
            return RecoveryStep((0.0, 0.0), True,
                                f"{self.name}: can't rotate in place because there is a potential collision")
        speed = turn_rate(dist_left, self.max_vel_theta, self.min_in_place_vel_theta, self.acc_lim_theta)
        return RecoveryStep((0.0, speed), False)


def create(context: RecoveryContext, name: str, params: dict) -> RotateRecovery:
    borrowed = context.planner_parameters("TrajectoryPlannerROS")
    return RotateRecovery(name, {**{k: borrowed[k] for k in BORROWED if k in borrowed}, **params},
                          context.footprint_clear)


SPEC = PluginSpec(ROTATE_RECOVERY, create, RotateParams)
