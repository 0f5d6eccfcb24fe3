"""Differential drive at wheel level: (v, w) commands to wheel speeds, and wheel odometry.

The limits act on the wheels, as a motor controller's do: a command beyond the top wheel speed is
scaled down along the same curvature, and each control step moves the wheel speeds towards their
targets by at most max_wheel_accel * dt (both wheels scaled together, so a ramp does not bend the
path). Odometry integrates the wheel encoders, not the true motion, so wheel slip and (optional)
encoder errors show up as odometry drift like on a real robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DiffDriveParams:
    """Wheel-level limits of the simplebot's drive (rad/s, rad/s^2, N*m, s).

    Defaults: 15 rad/s is 1.05 m/s at the 0.07 m wheel and 25 rad/s^2 is 1.75 m/s^2, both above the
    lab TEB limits (max_vel_x 0.4, acc_lim_x 0.5), so the planner, not the drive, shapes the motion.
    """

    max_wheel_speed: float = 15.0
    max_wheel_accel: float = 25.0
    max_wheel_torque: float = 5.0
    cmd_timeout: float = 0.5

    def __post_init__(self):
        for name in ("max_wheel_speed", "max_wheel_accel", "max_wheel_torque", "cmd_timeout"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value <= 0:
                raise ValueError(f"DiffDriveParams.{name} must be a positive number, got {value!r}")


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


def wheel_targets(v: float, w: float, separation: float, radius: float, max_speed: float) -> np.ndarray:
    """[left, right] wheel speeds (rad/s) for body velocity (v, w), saturated along the curvature.

    A command beyond what the drive can do is first scaled down (v and w together) to the drive's
    limits, so even 1e308 saturates instead of overflowing to inf and turning into NaN.
    Raises ValueError for a non-finite command.
    """
    if not (math.isfinite(v) and math.isfinite(w)):
        raise ValueError(f"cmd_vel must be finite, got linear.x={v}, angular.z={w}")
    half = separation / 2
    top_v = max_speed * radius
    scale = min(1.0, top_v / abs(v) if v else 1.0, top_v / half / abs(w) if w else 1.0)
    v, w = v * scale, w * scale
    targets = np.array([(v - w * half) / radius, (v + w * half) / radius])
    peak = np.max(np.abs(targets))
    if peak > max_speed:
        targets *= max_speed / peak
    return targets


def ramp(current: np.ndarray, target: np.ndarray, max_step: float) -> np.ndarray:
    """Move wheel speeds towards the targets by at most max_step, keeping the change's direction."""
    delta = target - current
    peak = np.max(np.abs(delta))
    if peak > max_step:
        delta = delta * (max_step / peak)
    return current + delta


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
