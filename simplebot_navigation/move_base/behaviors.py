"""Nav2's behaviours Spin, BackUp, DriveOnHeading and Wait (docs/reference.md §9.3), stepped by move_base's control
cycle like the recoveries, with their motion code (recovery/__init__.py).

Each checks its footprint against the local costmap over the next SIMULATE_AHEAD_S of its motion before every
step, as Nav2's behaviour server does, and ends with COLLISION_AHEAD when that motion would touch an obstacle.
The bounds on what a request may ask (``check_*``) are this project's: Nav2 takes the absolute value of a negative
backup distance and runs a time allowance of 0 forever, which a script's sign error turns into a robot that
drives the wrong way or never stops.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.move_base.recovery import turn_poses, turn_rate, unicycle_poses

#: Nav2 behavior_server's defaults
SIMULATE_AHEAD_S = 2.0
MAX_ROTATIONAL_VEL = 1.0
MIN_ROTATIONAL_VEL = 0.4
ROTATIONAL_ACC_LIM = 3.2
#: collision checks along a turn (rad) and along a straight drive (m)
TURN_CHECK_STEP = 0.017
DRIVE_CHECK_STEP_M = 0.01
#: a turn or a drive this close to its end is done
YAW_TOLERANCE = 0.02
DISTANCE_TOLERANCE_M = 0.005
#: bounds on a request
MAX_SPIN_RAD = 4.0 * math.pi
MAX_DRIVE_M = 10.0
MAX_DRIVE_SPEED = 1.0
MAX_TIME_S = 3600.0


@dataclass
class BehaviorStep:
    """One control period: the velocity to send, and, when the behaviour is over, its outcome (None while it runs;
    "" on success, else the name of the action's error code) and a message."""
    cmd: tuple[float, float]
    outcome: str | None = None
    message: str = ""


def check_time(value: float, field: str) -> str | None:
    """Why a duration cannot be run, naming ``field``; None when it can."""
    if not math.isfinite(value) or value <= 0.0 or value > MAX_TIME_S:
        return f"{field} must be in (0, {MAX_TIME_S:g}] s, got {value:g}"
    return None


def check_spin(target_yaw: float, time_allowance: float) -> str | None:
    if not math.isfinite(target_yaw) or abs(target_yaw) > MAX_SPIN_RAD:
        return f"target_yaw must be finite and within ±{MAX_SPIN_RAD:.4g} rad (two turns), got {target_yaw:g}"
    return check_time(time_allowance, "time_allowance")


def check_drive(x: float, y: float, z: float, speed: float, time_allowance: float, backup: bool) -> str | None:
    """A BackUp (``backup``: distance target.x >= 0, reversing at |speed|) or a DriveOnHeading (target.x and speed
    of one sign) request."""
    for field, value in (("target.x", x), ("target.y", y), ("target.z", z), ("speed", speed)):
        if not math.isfinite(value):
            return f"{field} must be finite, got {value:g}"
    if y != 0.0 or z != 0.0:
        return f"target.y and target.z must be 0 (the robot drives along its heading), got {y:g}, {z:g}"
    if backup and x < 0.0:
        return f"target.x is the distance to back up and must be >= 0, got {x:g}"
    if abs(x) > MAX_DRIVE_M:
        return f"target.x must be within ±{MAX_DRIVE_M:g} m, got {x:g}"
    if speed == 0.0 or abs(speed) > MAX_DRIVE_SPEED:
        return f"speed must be non-zero and within ±{MAX_DRIVE_SPEED:g} m/s, got {speed:g}"
    if not backup and (x > 0.0) != (speed > 0.0):
        return f"target.x ({x:g}) and speed ({speed:g}) must have the same sign"
    return check_time(time_allowance, "time_allowance")


class SpinBehavior:
    """Turn ``target_yaw`` (signed, rad) in place."""

    def __init__(self, target_yaw: float, time_allowance: float, footprint_clear: Callable[[np.ndarray], np.ndarray]):
        self.target = target_yaw
        self.time_allowance = time_allowance
        self._clear = footprint_clear
        self.turned = 0.0
        self._last_yaw = 0.0
        self._start = 0.0

    @property
    def progress(self) -> float:
        return abs(self.turned)

    def start(self, now: float, pose) -> None:
        self.turned, self._last_yaw, self._start = 0.0, pose[2], now

    def tick(self, now: float, pose) -> BehaviorStep:
        self.turned += float(normalize_theta(pose[2] - self._last_yaw))
        self._last_yaw = pose[2]
        direction = 1.0 if self.target >= 0 else -1.0
        left = abs(self.target) - direction * self.turned
        if left < YAW_TOLERANCE:
            return BehaviorStep((0.0, 0.0), "", f"turned {self.turned:.2f} rad")
        if now - self._start > self.time_allowance:
            return BehaviorStep((0.0, 0.0), "TIMEOUT", f"time_allowance of {self.time_allowance:g} s ran out after "
                                                       f"turning {self.turned:.2f} of {self.target:.2f} rad")
        rate = turn_rate(left, MAX_ROTATIONAL_VEL, MIN_ROTATIONAL_VEL, ROTATIONAL_ACC_LIM)
        ahead = turn_poses(pose, direction, min(left, rate * SIMULATE_AHEAD_S), TURN_CHECK_STEP)
        if not np.all(self._clear(ahead)):
            return BehaviorStep((0.0, 0.0), "COLLISION_AHEAD",
                                f"collision ahead: turning further would hit an obstacle (turned {self.turned:.2f} "
                                f"of {self.target:.2f} rad)")
        return BehaviorStep((0.0, direction * rate))


class DriveOnHeadingBehavior:
    """Drive ``distance`` (m, > 0) straight along the heading at ``speed`` (m/s, negative: backwards)."""

    def __init__(self, distance: float, speed: float, time_allowance: float,
                 footprint_clear: Callable[[np.ndarray], np.ndarray], period: float):
        self.distance = abs(distance)
        self.speed = speed
        self.time_allowance = time_allowance
        self._clear = footprint_clear
        self._period = period
        self._origin = (0.0, 0.0)
        self._start = 0.0
        self.travelled = 0.0

    @property
    def progress(self) -> float:
        return self.travelled

    def start(self, now: float, pose) -> None:
        self._origin, self._start, self.travelled = (pose[0], pose[1]), now, 0.0

    def tick(self, now: float, pose) -> BehaviorStep:
        self.travelled = math.hypot(pose[0] - self._origin[0], pose[1] - self._origin[1])
        left = self.distance - self.travelled
        if left < DISTANCE_TOLERANCE_M:
            return BehaviorStep((0.0, 0.0), "", f"drove {self.travelled:.3f} m")
        if now - self._start > self.time_allowance:
            return BehaviorStep((0.0, 0.0), "TIMEOUT", f"time_allowance of {self.time_allowance:g} s ran out after "
                                                       f"{self.travelled:.3f} of {self.distance:g} m")
        # the last period's speed lands on the end rather than beyond it
        speed = math.copysign(min(abs(self.speed), left / self._period), self.speed)
        duration = min(SIMULATE_AHEAD_S, left / abs(speed))
        ahead = unicycle_poses(pose, speed, 0.0, duration, DRIVE_CHECK_STEP_M / abs(speed))
        if not np.all(self._clear(ahead)):
            return BehaviorStep((0.0, 0.0), "COLLISION_AHEAD",
                                f"collision ahead: driving {'back' if speed < 0 else 'on'} further would hit an "
                                f"obstacle (drove {self.travelled:.3f} of {self.distance:g} m)")
        return BehaviorStep((speed, 0.0))


class WaitBehavior:
    """Stand still for ``duration`` seconds."""

    def __init__(self, duration: float):
        self.duration = duration
        self._start = 0.0
        self.time_left = duration

    @property
    def progress(self) -> float:
        return self.duration - self.time_left

    def start(self, now: float, pose) -> None:
        self._start, self.time_left = now, self.duration

    def tick(self, now: float, pose) -> BehaviorStep:
        self.time_left = max(0.0, self.duration - (now - self._start))
        if self.time_left <= 0.0:
            return BehaviorStep((0.0, 0.0), "", f"waited {self.duration:g} s")
        return BehaviorStep((0.0, 0.0))
