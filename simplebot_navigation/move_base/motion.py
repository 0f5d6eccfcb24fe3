"""Stepped motion in place and along the ground, one control period at a time: the turn (TurnInPlace) and the
drive (Drive) that the recoveries (recovery/: rotate, spin, backup) and Nav2's behaviours (behaviors.py: Spin,
BackUp, DriveOnHeading) are made of.

Each knows how far it has come since start(), ends when within its tolerance of the target or past its time
allowance, and checks the footprint against the local costmap along the motion ahead before the step is taken.
Its user says how far, how fast and how far ahead to look, and what a collision ahead means to it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.geometry import normalize_theta

#: how a motion ended, named as Nav2's behaviour actions name their error codes ("": it reached its target)
SUCCEEDED, TIMEOUT, COLLISION_AHEAD = "", "TIMEOUT", "COLLISION_AHEAD"
#: a drive's collision checks are this far apart along its motion (m)
DRIVE_CHECK_STEP_M = 0.01

FootprintCheck = Callable[[np.ndarray], np.ndarray]   # per (x, y, yaw) row: the footprint there is free


@dataclass
class TurnStep:
    """One control period of a turn: the velocity to send, and how it ended (None while it runs)."""
    cmd: tuple[float, float]
    outcome: str | None = None


def turn_rate(left: float, max_vel: float, min_vel: float, acc_lim: float) -> float:
    """Turn rate (rad/s, >= 0) with ``left`` rad still to turn: as fast as allowed, slowing so that the
    acceleration limit stops the turn at its end, never below the minimum rate."""
    return min(max_vel, max(min_vel, math.sqrt(2.0 * acc_lim * max(left, 0.0))))


def turn_poses(pose, direction: float, angle: float, step: float) -> np.ndarray:
    """Poses of a turn in place from ``pose`` by ``angle`` (rad, >= 0) in ``direction`` (+1 left, -1 right),
    one every ``step`` rad, the start excluded and the end included."""
    sweep = np.arange(1, int(angle / step) + 1) * step
    if not len(sweep) or sweep[-1] < angle:
        sweep = np.append(sweep, angle)
    return np.column_stack([np.full_like(sweep, pose[0]), np.full_like(sweep, pose[1]), pose[2] + direction * sweep])


def unicycle_poses(pose, v: float, omega: float, duration: float, step: float) -> np.ndarray:
    """Poses of a diff-drive robot holding (v, omega) from ``pose``, one per ``step`` seconds, the start excluded."""
    t = np.arange(1, max(1, int(math.ceil(duration / step))) + 1) * step
    yaw = pose[2] + omega * t
    if abs(omega) < 1e-9:
        x, y = pose[0] + v * t * math.cos(pose[2]), pose[1] + v * t * math.sin(pose[2])
    else:
        x = pose[0] + v / omega * (np.sin(yaw) - math.sin(pose[2]))
        y = pose[1] - v / omega * (np.cos(yaw) - math.cos(pose[2]))
    return np.column_stack([x, y, yaw])


class TurnInPlace:
    """A turn in place by a signed angle (rad, + left), from the yaw at start().

    ``sweep(pose, direction, angle, step)`` gives the poses the footprint is checked at along the turn ahead
    (turn_poses unless its user checks differently)."""

    def __init__(self, footprint_clear: FootprintCheck, sweep: Callable[..., np.ndarray] = turn_poses):
        self._clear = footprint_clear
        self._sweep = sweep
        self.target = 0.0
        self.turned = 0.0           # signed, since start()
        self.tolerance = 0.0
        self.check_step = 0.0
        self.time_allowance = math.inf
        self._last_yaw = 0.0
        self._start = 0.0

    @property
    def direction(self) -> float:
        return 1.0 if self.target >= 0 else -1.0

    def start(self, now: float, pose, target: float, tolerance: float, check_step: float,
              time_allowance: float = math.inf) -> None:
        """Turn ``target`` from ``pose``, done within ``tolerance`` (rad) of it, the footprint checked every
        ``check_step`` (rad) of the turn ahead."""
        self.target, self.tolerance, self.check_step = target, tolerance, check_step
        self.time_allowance, self.turned, self._last_yaw, self._start = time_allowance, 0.0, pose[2], now

    def step(self, now: float, pose, max_vel: float, min_vel: float, acc_lim: float,
             look_ahead: float | None = None) -> TurnStep:
        """The turn rate for what is left (turn_rate), after checking the turn the next ``look_ahead`` seconds at
        that rate would make (None: the whole rest of the turn)."""
        self.turned += float(normalize_theta(pose[2] - self._last_yaw))
        self._last_yaw = pose[2]
        left = abs(self.target) - self.direction * self.turned
        if left < self.tolerance:
            return TurnStep((0.0, 0.0), SUCCEEDED)
        if now - self._start > self.time_allowance:
            return TurnStep((0.0, 0.0), TIMEOUT)
        rate = turn_rate(left, max_vel, min_vel, acc_lim)
        angle = left if look_ahead is None else min(left, rate * look_ahead)
        if not np.all(self._clear(self._sweep(pose, self.direction, angle, self.check_step))):
            return TurnStep((0.0, 0.0), COLLISION_AHEAD)
        return TurnStep((0.0, self.direction * rate))


class Drive:
    """A drive of a distance (m, >= 0) from the pose at start(). Its user picks the velocity of each step from what
    is left (``left``) and asks ``time_to_collision`` of it; ``along_path`` measures the length of the path driven
    (a drive that follows a curve), else the straight-line distance from the start, as Nav2's DriveOnHeading does."""

    def __init__(self, footprint_clear: FootprintCheck, tolerance: float, along_path: bool = False):
        self._clear = footprint_clear
        self.tolerance = tolerance
        self.along_path = along_path
        self.distance = 0.0
        self.travelled = 0.0
        self.time_allowance = math.inf
        self._origin = (0.0, 0.0)
        self._last = (0.0, 0.0)
        self._start = 0.0

    @property
    def left(self) -> float:
        return self.distance - self.travelled

    def start(self, now: float, pose, distance: float, time_allowance: float = math.inf) -> None:
        self.distance, self.time_allowance = distance, time_allowance
        self._origin = self._last = (pose[0], pose[1])
        self._start, self.travelled = now, 0.0

    def advance(self, now: float, pose) -> str | None:
        """Measure the progress to ``pose``: SUCCEEDED within the tolerance of the distance, TIMEOUT past the time
        allowance, else None (the user steps on)."""
        x, y = pose[0], pose[1]
        if self.along_path:
            self.travelled += math.hypot(x - self._last[0], y - self._last[1])
            self._last = (x, y)
        else:
            self.travelled = math.hypot(x - self._origin[0], y - self._origin[1])
        if self.left < self.tolerance:
            return SUCCEEDED
        if now - self._start > self.time_allowance:
            return TIMEOUT
        return None

    def time_to_collision(self, pose, v: float, omega: float, look_ahead: float) -> float:
        """Seconds until the footprint, holding (v, omega) from ``pose``, first touches an obstacle, checked every
        DRIVE_CHECK_STEP_M over the next ``look_ahead`` seconds up to the end of the drive; inf when all is free."""
        step = DRIVE_CHECK_STEP_M / abs(v)
        poses = unicycle_poses(pose, v, omega, min(look_ahead, self.left / abs(v)), step)
        blocked = np.nonzero(~np.asarray(self._clear(poses), dtype=bool))[0]
        return float((blocked[0] + 1) * step) if len(blocked) else math.inf
