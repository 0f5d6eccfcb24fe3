"""Differential drive at wheel level: (v, w) commands to wheel speeds, and wheel odometry.

The limits act on the wheels, as a motor controller's do: a command beyond the top wheel speed (or the
top yaw rate, where the drive has one) is scaled down along the same curvature, and each control step
moves the wheel speeds towards their targets by at most max_wheel_accel * dt (and their difference by
what max_yaw_accel allows), both wheels scaled together, so a ramp does not bend the path. Odometry
integrates the wheel encoders, not the true motion, so wheel slip and (optional) encoder errors show up
as odometry drift like on a real robot.

Two drives exist: the lab's (DiffDriveParams' defaults, every body up to 1.05 m/s) and a Clearpath
Jackal's for the round body above that (jackal_drive(); drive_for() picks one from a body and a top speed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simplebot_description import RobotDescription

# A Clearpath Jackal's drive, at body level. Top speed and yaw rate: Clearpath's published 2.0 m/s, and the
# robot's ROS control configuration (github.com/jackal/jackal, jackal_control/config/control.yaml:
# linear.x.max_velocity 2.0, angular.z.max_velocity 4.0). That file's acceleration limits (20 m/s^2,
# 25 rad/s^2) are set above anything the robot can do, so the two below are chosen (DiffDriveParams).
JACKAL_MAX_SPEED = 2.0
JACKAL_MAX_YAW_RATE = 4.0
JACKAL_ACCEL = 2.5
JACKAL_YAW_ACCEL = 8.0
#: the Jackal drive's wheel torque is this many times what JACKAL_ACCEL takes for the body's mass
TORQUE_MARGIN = 2.0


@dataclass(frozen=True)
class DiffDriveParams:
    """Wheel-level limits of a drive (rad/s, rad/s^2, N*m, s), and optional yaw limits (rad/s, rad/s^2).

    Defaults, the lab's drive: 15 rad/s is 1.05 m/s at the 0.07 m wheel and 25 rad/s^2 is 1.75 m/s^2, both
    above the lab TEB limits (max_vel_x 0.4, acc_lim_x 0.5), so the planner, not the drive, shapes the
    motion; no yaw limits beyond the wheels'.

    The Jackal drive (jackal_drive(), the round body above 1.05 m/s; docs/reference.md §11):
    2.0 m/s and 4.0 rad/s, Clearpath's published top speed and the Jackal's control.yaml velocity limits.
    2.5 m/s^2 (0.25 g): a 17 kg four-wheel robot on rubber (mu about 0.5, as its Gazebo model has) can brake
    at most at mu * g, about 4.9 m/s^2; half of that is a hard stop that leaves grip for steering, 0.8 m
    from 2.0 m/s. 8 rad/s^2: the 4 rad/s top in 0.5 s; a skid-steer spends much of its torque scrubbing its
    tyres sideways when it turns, so it cannot spin up at the 2 a / track (13 rad/s^2) its rims would allow.
    The wheel stays 0.07 m (the Jackal's is 0.098 m): only the wheel-speed limit rises, to 28.6 rad/s.
    The wheel torque is TORQUE_MARGIN times what 2.5 m/s^2 takes for the body's mass, so the ramp, not the
    motor, shapes the motion, and grip stays physical (mu 1 on the driven wheels, sim/robot.py).
    """

    max_wheel_speed: float = 15.0
    max_wheel_accel: float = 25.0
    max_wheel_torque: float = 5.0
    cmd_timeout: float = 0.5
    max_yaw_rate: float | None = None
    max_yaw_accel: float | None = None

    def __post_init__(self):
        for name in ("max_wheel_speed", "max_wheel_accel", "max_wheel_torque", "cmd_timeout",
                     "max_yaw_rate", "max_yaw_accel"):
            value = getattr(self, name)
            if value is None and name.startswith("max_yaw"):
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value <= 0:
                raise ValueError(f"DiffDriveParams.{name} must be a positive number, got {value!r}")


def jackal_drive(description: RobotDescription) -> DiffDriveParams:
    """A Clearpath Jackal's limits at this body's wheels, its torque sized to this body's mass."""
    radius = description.wheel_radius
    return DiffDriveParams(max_wheel_speed=JACKAL_MAX_SPEED / radius, max_wheel_accel=JACKAL_ACCEL / radius,
                           max_wheel_torque=TORQUE_MARGIN * description.mass * JACKAL_ACCEL * radius / 2,
                           max_yaw_rate=JACKAL_MAX_YAW_RATE, max_yaw_accel=JACKAL_YAW_ACCEL)


def drive_for(description: RobotDescription, max_speed: float | None = None) -> DiffDriveParams:
    """The drive of a body asked to reach max_speed (m/s; None: the lab's drive).

    Up to the lab drive's top speed (1.05 m/s) every body keeps that drive, so nothing changes; above it
    the round body gets the Jackal drive, up to JACKAL_MAX_SPEED. The box is the lab's robot and keeps its
    drive: above its top speed it is refused. ValueError says which value is wrong and its limit.
    """
    lab = DiffDriveParams()
    if max_speed is None:
        return lab
    if isinstance(max_speed, bool) or not isinstance(max_speed, (int, float)) \
            or not math.isfinite(max_speed) or max_speed <= 0:
        raise ValueError(f"expected a positive number of m/s, got {max_speed!r}")
    lab_top = lab.max_wheel_speed * description.wheel_radius
    if max_speed <= lab_top + 1e-9:
        return lab
    if description.body != "round":
        raise ValueError(f"{max_speed:g} m/s is above the {description.body}'s top speed of {lab_top:g} m/s "
                         f"(the lab's drive; the round body's goes up to {JACKAL_MAX_SPEED:g} m/s)")
    if max_speed > JACKAL_MAX_SPEED:
        raise ValueError(f"{max_speed:g} m/s is above the round body's top speed of {JACKAL_MAX_SPEED:g} m/s "
                         "(a Clearpath Jackal's)")
    return jackal_drive(description)


@dataclass(frozen=True)
class OdomNoise:
    """Encoder errors: a per-wheel scale error drawn once (drift) and per-step speed noise.

    Both are relative standard deviations (0.01 = 1 %).
    """

    scale_std: float = 0.0
    speed_std: float = 0.0

    def __post_init__(self):
        for name in ("scale_std", "speed_std"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value < 0:
                raise ValueError(f"OdomNoise.{name} must be a number >= 0, got {value!r}")


def wheel_targets(v: float, w: float, separation: float, radius: float, max_speed: float,
                  max_yaw_rate: float | None = None) -> np.ndarray:
    """[left, right] wheel speeds (rad/s) for body velocity (v, w), saturated along the curvature.

    A command beyond what the drive can do (max_speed at the wheels, max_yaw_rate of the body) is first
    scaled down (v and w together) to the drive's limits, so even 1e308 saturates instead of overflowing
    to inf and turning into NaN. Raises ValueError for a non-finite command.
    """
    if not (math.isfinite(v) and math.isfinite(w)):
        raise ValueError(f"cmd_vel must be finite, got linear.x={v}, angular.z={w}")
    half = separation / 2
    top_v = max_speed * radius
    top_w = top_v / half if max_yaw_rate is None else min(top_v / half, max_yaw_rate)
    scale = min(1.0, top_v / abs(v) if v else 1.0, top_w / abs(w) if w else 1.0)
    v, w = v * scale, w * scale
    targets = np.array([(v - w * half) / radius, (v + w * half) / radius])
    peak = np.max(np.abs(targets))
    if peak > max_speed:
        targets *= max_speed / peak
    return targets


def ramp(current: np.ndarray, target: np.ndarray, max_step: float, max_turn_step: float | None = None) -> np.ndarray:
    """Move wheel speeds towards the targets by at most max_step each, and their difference (right - left,
    the yaw rate's share) by at most max_turn_step, keeping the change's direction."""
    delta = target - current
    scale = 1.0
    peak = np.max(np.abs(delta))
    if peak > max_step:
        scale = max_step / peak
    if max_turn_step is not None:
        turn = abs(delta[1] - delta[0])
        if turn * scale > max_turn_step:
            scale = max_turn_step / turn
    return current + delta * scale if scale < 1.0 else current + delta


class WheelOdometry:
    """Pose and twist in the odom frame, integrated from wheel speeds (exact for constant speeds)."""

    def __init__(self, separation: float, radius: float, noise: OdomNoise | None = None,
                 rng: np.random.Generator | None = None):
        self.separation = separation
        self.radius = radius
        self.noise = noise or OdomNoise()
        self._rng = rng if rng is not None else np.random.default_rng(0)
        # Encoder scale error per wheel, fixed for the run: this is what makes odometry drift.
        self._scale = 1.0 + self._rng.normal(0.0, self.noise.scale_std, 2) if self.noise.scale_std \
            else np.ones(2)
        self.x = self.y = self.yaw = 0.0
        self.v = self.w = 0.0

    def update(self, wheel_speeds, dt: float) -> None:
        """Integrate one step; non-finite input raises ValueError and leaves the pose as it was."""
        speeds = np.asarray(wheel_speeds, dtype=float)
        if not (np.isfinite(speeds).all() and math.isfinite(dt)):
            raise ValueError(f"wheel odometry needs finite wheel speeds and dt, got {speeds.tolist()} "
                             f"and dt={dt}")
        speeds = speeds * self._scale
        if self.noise.speed_std:
            speeds = speeds * (1.0 + self._rng.normal(0.0, self.noise.speed_std, 2))
        left, right = (float(s) * self.radius for s in speeds)
        self.v = (left + right) / 2
        self.w = (right - left) / self.separation
        dtheta = self.w * dt
        # Arc of constant curvature: chord length along the mean heading.
        chord = self.v * dt * (math.sin(dtheta / 2) / (dtheta / 2) if abs(dtheta) > 1e-9 else 1.0)
        heading = self.yaw + dtheta / 2
        self.x += chord * math.cos(heading)
        self.y += chord * math.sin(heading)
        self.yaw = math.remainder(self.yaw + dtheta, math.tau)
