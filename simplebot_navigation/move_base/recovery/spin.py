"""spin_recovery/SpinRecovery: turn as far as the footprint allows towards the freer side (Nav2's Spin)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE
from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.parameters import param
from simplebot_navigation.move_base.motion import COLLISION_AHEAD, SUCCEEDED, TIMEOUT, TurnInPlace, turn_poses
from simplebot_navigation.move_base.recovery import ParameterisedRecovery, RecoveryContext, RecoveryStep

SPIN_RECOVERY = "spin_recovery/SpinRecovery"

#: the free area is weighed within this many circumscribed radii on either side
FREE_SPACE_RADII = 2.0
#: a turn this close to its end is done (rad)
YAW_TOLERANCE = 0.03

@dataclass
class SpinParams:
    """The ``<name>/`` namespace of a spin_recovery/SpinRecovery (Nav2 Spin's parameters)."""
    spin_dist: float = param(math.pi / 2, "rad", "turn wanted towards the freer side", gt=0)
    max_rotational_vel: float = param(1.0, "rad/s", "maximum turn rate", gt=0)
    min_rotational_vel: float = param(0.4, "rad/s", "minimum turn rate", ge=0)
    rotational_acc_lim: float = param(3.2, "rad/s^2", "angular acceleration limit", gt=0)
    sim_granularity: float = param(0.017, "rad", "turn between two collision checks", gt=0)
    time_allowance: float = param(10.0, "s", "time after which the behaviour gives up", gt=0)


def free_area_left_right(costmap, pose, radius: float) -> tuple[float, float]:
    """Known free area (m^2, cells below the inscribed cost) within ``radius`` on the robot's left and right."""
    x, y, yaw = pose
    res = costmap.resolution
    offsets = np.arange(-radius, radius + res, res)
    dx, dy = np.meshgrid(offsets, offsets)
    inside = np.hypot(dx, dy) <= radius
    dx, dy = dx[inside], dy[inside]
    mx, my, on_map = costmap.world_to_map_array(x + dx, y + dy)
    cost = costmap.costmap[my[on_map], mx[on_map]]
    free = (cost < INSCRIBED_INFLATED_OBSTACLE)
    lateral = (-math.sin(yaw) * dx + math.cos(yaw) * dy)[on_map]
    return float(free[lateral > 0].sum() * res * res), float(free[lateral < 0].sum() * res * res)


class SpinRecovery(ParameterisedRecovery):
    """Turn spin_dist in place towards the side with more free space, or as far as the footprint can.

    free_space(pose) gives the free area on the robot's left and right; footprint_clear(poses)
    checks each (x, y, yaw) row. Where a full circle is blocked, part of a turn still changes
    what the local planner can start from.
    """

    PARAMS = SpinParams

    def __init__(self, name: str, params: dict, footprint_clear: Callable[[np.ndarray], np.ndarray],
                 free_space: Callable[[tuple[float, float, float]], tuple[float, float]]):
        self.name = name
        self._clear = footprint_clear
        self._free_space = free_space
        self._turn = TurnInPlace(footprint_clear)
        self._refused = ""
        self.warnings = self.configure(params)

    def _reachable(self, pose, direction: float) -> float:
        """How far (rad, up to spin_dist) the footprint turns in ``direction`` before a collision."""
        poses = turn_poses(pose, direction, self.spin_dist, self.sim_granularity)
        blocked = np.nonzero(~np.asarray(self._clear(poses), dtype=bool))[0]
        if not len(blocked):
            return self.spin_dist
        return float(abs(poses[blocked[0] - 1, 2] - pose[2])) if blocked[0] > 0 else 0.0

    def start(self, now: float, pose) -> None:
        left_free, right_free = self._free_space(pose)
        preferred = 1.0 if left_free >= right_free else -1.0
        reach = {d: self._reachable(pose, d) for d in (preferred, -preferred)}
        # the freer side, unless the footprint turns clearly further the other way
        direction = preferred if reach[preferred] >= 0.5 * reach[-preferred] else -preferred
        self._refused = "" if reach[direction] > self.sim_granularity else \
            f"{self.name}: can't turn in place either way because there is a potential collision"
        self._turn.start(now, pose, direction * reach[direction], YAW_TOLERANCE, self.sim_granularity,
                         self.time_allowance)

    def tick(self, now: float, pose) -> RecoveryStep:
        if self._refused:
            return RecoveryStep((0.0, 0.0), True, self._refused)
        step = self._turn.step(now, pose, self.max_rotational_vel, self.min_rotational_vel, self.rotational_acc_lim)
        turned = abs(self._turn.turned)
        side = "left" if self._turn.target > 0 else "right"
        if step.outcome == SUCCEEDED:
            return RecoveryStep(step.cmd, True, f"{self.name}: turned {turned:.2f} rad to the {side}")
        if step.outcome == COLLISION_AHEAD:
            return RecoveryStep(step.cmd, True, f"{self.name}: stopped after {turned:.2f} rad to the {side}, "
                                                "a collision lies further")
        if step.outcome == TIMEOUT:
            return RecoveryStep(step.cmd, True, f"{self.name}: gave up after {self._turn.time_allowance:g} s")
        return RecoveryStep(step.cmd, False)


def create(context: RecoveryContext, name: str, params: dict) -> SpinRecovery:
    radius = FREE_SPACE_RADII * context.circumscribed_radius
    return SpinRecovery(name, params, context.footprint_clear, lambda pose: context.free_space(pose, radius))


SPEC = PluginSpec(SPIN_RECOVERY, create, SpinParams)
