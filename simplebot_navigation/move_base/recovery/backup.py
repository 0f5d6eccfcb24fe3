"""backup_recovery/BackUpRecovery: reverse along the path the robot came by (Nav2's BackUp)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.parameters import param
from simplebot_navigation.move_base.motion import SUCCEEDED, TIMEOUT, Drive
from simplebot_navigation.move_base.recovery import ParameterisedRecovery, PoseTrail, RecoveryContext, RecoveryStep

BACKUP_RECOVERY = "backup_recovery/BackUpRecovery"

@dataclass
class BackUpParams:
    """The ``<name>/`` namespace of a backup_recovery/BackUpRecovery (Nav2 BackUp's parameters)."""
    backup_dist: float = param(0.3, "m", "distance to reverse", gt=0)
    backup_speed: float = param(0.15, "m/s", "reversing speed", gt=0)
    max_rotational_vel: float = param(1.0, "rad/s", "turn rate limit while following the recent path", gt=0)
    simulate_ahead_time: float = param(2.0, "s", "motion checked for collisions ahead of each step", ge=0)
    time_allowance: float = param(10.0, "s", "time after which the behaviour gives up", gt=0)


class BackUpRecovery(ParameterisedRecovery):
    """Reverse backup_dist along the robot's recent path (straight back when it has none).

    footprint_clear(poses) says per (x, y, yaw) row whether the footprint is collision free; the
    motion of the next simulate_ahead_time is checked before every step, as Nav2's BackUp does.
    Nav2 gives up as soon as a collision shows up in that window; here the robot keeps reversing
    until the collision is STOP_MARGIN_S away, because in a tight spot every centimetre counts.
    """

    PARAMS = BackUpParams

    LOOKAHEAD_M = 0.15   # carrot distance along the trail: short, because the trail is what is known free
    STOP_MARGIN_S = 0.25  # a few control periods of reversing
    DISTANCE_TOLERANCE_M = 0.01

    def __init__(self, name: str, params: dict, footprint_clear: Callable[[np.ndarray], np.ndarray],
                 trail: PoseTrail):
        self.name = name
        self._trail = trail
        self._route = np.empty((0, 2))
        self._drive = Drive(footprint_clear, self.DISTANCE_TOLERANCE_M, along_path=True)
        self.warnings = self.configure(params)

    def start(self, now: float, pose) -> None:
        x, y, yaw = pose
        self._route = self._trail.back_from(x, y, self.backup_dist + self.LOOKAHEAD_M)
        if not len(self._route):
            self._route = np.array([[x - math.cos(yaw) * self.backup_dist, y - math.sin(yaw) * self.backup_dist]])
        self._drive.start(now, pose, self.backup_dist, self.time_allowance)

    def tick(self, now: float, pose) -> RecoveryStep:
        outcome = self._drive.advance(now, pose)
        driven = self._drive.travelled
        if outcome == SUCCEEDED:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: backed up {driven:.2f} m")
        if outcome == TIMEOUT:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: gave up after {self._drive.time_allowance:g} s, "
                                                  f"backed up {driven:.2f} m")
        omega = self._steer(*pose)
        ahead = self._drive.time_to_collision(pose, -self.backup_speed, omega, self.simulate_ahead_time)
        if ahead < self.STOP_MARGIN_S:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: stopped after {driven:.2f} m, "
                                                  "a collision lies behind the robot")
        return RecoveryStep((-self.backup_speed, omega), False)

    def _steer(self, x: float, y: float, yaw: float) -> float:
        """Pure pursuit in reverse: the turn rate that brings the rear onto the carrot point."""
        distances = np.hypot(self._route[:, 0] - x, self._route[:, 1] - y)
        nearest = int(np.argmin(distances))
        beyond = np.nonzero(distances[nearest:] >= self.LOOKAHEAD_M)[0]
        tx, ty = self._route[nearest + beyond[0]] if len(beyond) else self._route[-1]
        alpha = normalize_theta(math.atan2(ty - y, tx - x) - (yaw + math.pi))
        if abs(alpha) > math.pi / 2:   # the carrot lies ahead: the trail turned sharper than reversing can
            return 0.0
        curvature = 2.0 * math.sin(alpha) / max(math.hypot(tx - x, ty - y), 1e-3)
        return float(np.clip(self.backup_speed * curvature, -self.max_rotational_vel, self.max_rotational_vel))


def create(context: RecoveryContext, name: str, params: dict) -> BackUpRecovery:
    return BackUpRecovery(name, params, context.footprint_clear, context.trail)


SPEC = PluginSpec(BACKUP_RECOVERY, create, BackUpParams)
