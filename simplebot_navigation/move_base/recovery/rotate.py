"""rotate_recovery/RotateRecovery: a full turn in place, as ROS 1's."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.parameters import param
from simplebot_navigation.move_base.motion import COLLISION_AHEAD, SUCCEEDED, TurnInPlace
from simplebot_navigation.move_base.recovery import ParameterisedRecovery, RecoveryContext, RecoveryStep

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


def sweep_from_here(pose, direction: float, angle: float, step: float) -> np.ndarray:
    """The poses RotateRecovery checks before a step: the turn left from where the robot stands (as ROS 1 checks),
    its start and end included, evenly spaced at ``step`` or a little more."""
    yaws = pose[2] + direction * np.linspace(0.0, angle, max(1, int(angle / step)) + 1)
    return np.column_stack([np.full_like(yaws, pose[0]), np.full_like(yaws, pose[1]), yaws])


class RotateRecovery(ParameterisedRecovery):
    """Turn a full circle in place (counter-clockwise) to let the sensors see everything around.

    footprint_clear(poses) says per (x, y, yaw) row whether the footprint is collision free on the
    local costmap; the remaining turn is checked every sim_granularity before each step, as ROS 1 does.
    """

    PARAMS = RotateParams

    def __init__(self, name: str, params: dict, footprint_clear: Callable[[np.ndarray], np.ndarray]):
        self.name = name
        self._turn = TurnInPlace(footprint_clear, sweep_from_here)
        self.warnings = self.configure(params)

    def start(self, now: float, pose) -> None:
        self._turn.start(now, pose, 2.0 * math.pi, self.yaw_goal_tolerance, self.sim_granularity)

    def tick(self, now: float, pose) -> RecoveryStep:
        step = self._turn.step(now, pose, self.max_vel_theta, self.min_in_place_vel_theta, self.acc_lim_theta)
        if step.outcome == SUCCEEDED:
            return RecoveryStep(step.cmd, True, f"{self.name}: turned a full circle")
        if step.outcome == COLLISION_AHEAD:
            return RecoveryStep(step.cmd, True,
                                f"{self.name}: can't rotate in place because there is a potential collision")
        return RecoveryStep(step.cmd, False)


def create(context: RecoveryContext, name: str, params: dict) -> RotateRecovery:
    borrowed = context.planner_parameters("TrajectoryPlannerROS")
    return RotateRecovery(name, {**{k: borrowed[k] for k in BORROWED if k in borrowed}, **params},
                          context.footprint_clear)


SPEC = PluginSpec(ROTATE_RECOVERY, create, RotateParams)
