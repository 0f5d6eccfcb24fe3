"""Nav2's behaviours Spin, BackUp, DriveOnHeading and Wait (docs/reference.md §9.3), stepped by move_base's control
cycle like the recoveries, with the same turn and drive (motion.py).

Each checks its footprint against the local costmap over the next ``simulate_ahead_time`` of its motion before
every step, as Nav2's behaviour server does, and ends with COLLISION_AHEAD when that motion would touch an obstacle.
Their limits are Nav2 behavior_server's parameters, under move_base's ``behavior_server`` namespace
(BehaviorServerParams); a behaviour takes the values there are when it is requested.
The bounds on what a request may ask (``check_*``) are this project's: Nav2 takes the absolute value of a negative
backup distance and runs a time allowance of 0 forever, which a script's sign error turns into a robot that
drives the wrong way or never stops.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from simplebot_navigation.move_base.motion import (COLLISION_AHEAD, SUCCEEDED, TIMEOUT, Drive, FootprintCheck,
                                                   TurnInPlace)
from simplebot_navigation.parameters import ParameterError, build, param
from simplebot_navigation.teb.config import MAX_DRIVE_TURN_RATE

#: collision checks along a turn (rad)
TURN_CHECK_STEP = 0.017
#: a turn or a drive this close to its end is done
YAW_TOLERANCE = 0.02
DISTANCE_TOLERANCE_M = 0.005
#: bounds on a request
MAX_SPIN_RAD = 4.0 * math.pi
MAX_DRIVE_M = 10.0
MAX_DRIVE_SPEED = 1.0
MAX_TIME_S = 3600.0


@dataclass
class BehaviorServerParams:
    """move_base's ``behavior_server`` namespace: Nav2 behavior_server's limits on its behaviours, with its names and
    defaults."""
    simulate_ahead_time: float = param(2.0, "s", "motion of a Spin, BackUp or DriveOnHeading checked for collisions "
                                       "ahead of each step", gt=0, le=10.0)
    max_rotational_vel: float = param(1.0, "rad/s", "fastest turn of a Spin", gt=0, le=MAX_DRIVE_TURN_RATE)
    min_rotational_vel: float = param(0.4, "rad/s", "slowest turn of a Spin, at most max_rotational_vel", ge=0,
                                      le=MAX_DRIVE_TURN_RATE)
    rotational_acc_lim: float = param(3.2, "rad/s^2", "deceleration of a Spin towards its end", gt=0, le=50.0)
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_params(cls, given, where: str = "move_base/behavior_server") -> BehaviorServerParams:
        """Checked values of one namespace (ParameterError names the key), with the relation between them."""
        params, warnings = build(cls, given, where)
        params.warnings = warnings
        if params.min_rotational_vel > params.max_rotational_vel:
            raise ParameterError(f"{where}/min_rotational_vel: must be at most max_rotational_vel "
                                 f"({params.max_rotational_vel:g}), got {params.min_rotational_vel!r}")
        return params


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
    for name, value in (("target.x", x), ("target.y", y), ("target.z", z), ("speed", speed)):
        if not math.isfinite(value):
            return f"{name} must be finite, got {value:g}"
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

    def __init__(self, target_yaw: float, time_allowance: float, footprint_clear: FootprintCheck,
                 params: BehaviorServerParams):
        self.target = target_yaw
        self.time_allowance = time_allowance
        self.params = params
        self._turn = TurnInPlace(footprint_clear)

    @property
    def turned(self) -> float:
        return self._turn.turned

    @property
    def progress(self) -> float:
        return abs(self.turned)

    def start(self, now: float, pose) -> None:
        self._turn.start(now, pose, self.target, YAW_TOLERANCE, TURN_CHECK_STEP, self.time_allowance)

    def tick(self, now: float, pose) -> BehaviorStep:
        p = self.params
        step = self._turn.step(now, pose, p.max_rotational_vel, p.min_rotational_vel, p.rotational_acc_lim,
                               p.simulate_ahead_time)
        if step.outcome == SUCCEEDED:
            return BehaviorStep(step.cmd, SUCCEEDED, f"turned {self.turned:.2f} rad")
        if step.outcome == TIMEOUT:
            return BehaviorStep(step.cmd, TIMEOUT, f"time_allowance of {self.time_allowance:g} s ran out after "
                                                   f"turning {self.turned:.2f} of {self.target:.2f} rad")
        if step.outcome == COLLISION_AHEAD:
            return BehaviorStep(step.cmd, COLLISION_AHEAD,
                                f"collision ahead: turning further would hit an obstacle (turned {self.turned:.2f} "
                                f"of {self.target:.2f} rad)")
        return BehaviorStep(step.cmd)


class DriveOnHeadingBehavior:
    """Drive ``distance`` (m, > 0) straight along the heading at ``speed`` (m/s, negative: backwards)."""

    def __init__(self, distance: float, speed: float, time_allowance: float, footprint_clear: FootprintCheck,
                 period: float, params: BehaviorServerParams):
        self.distance = abs(distance)
        self.speed = speed
        self.time_allowance = time_allowance
        self.params = params
        self._period = period
        self._drive = Drive(footprint_clear, DISTANCE_TOLERANCE_M)

    @property
    def travelled(self) -> float:
        return self._drive.travelled

    @property
    def progress(self) -> float:
        return self.travelled

    def start(self, now: float, pose) -> None:
        self._drive.start(now, pose, self.distance, self.time_allowance)

    def tick(self, now: float, pose) -> BehaviorStep:
        outcome = self._drive.advance(now, pose)
        if outcome == SUCCEEDED:
            return BehaviorStep((0.0, 0.0), SUCCEEDED, f"drove {self.travelled:.3f} m")
        if outcome == TIMEOUT:
            return BehaviorStep((0.0, 0.0), TIMEOUT, f"time_allowance of {self.time_allowance:g} s ran out after "
                                                     f"{self.travelled:.3f} of {self.distance:g} m")
        # the last period's speed lands on the end rather than beyond it
        speed = math.copysign(min(abs(self.speed), self._drive.left / self._period), self.speed)
        if self._drive.time_to_collision(pose, speed, 0.0, self.params.simulate_ahead_time) < math.inf:
            return BehaviorStep((0.0, 0.0), COLLISION_AHEAD,
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
