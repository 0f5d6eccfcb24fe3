"""mppi_local_planner/MPPILocalPlannerROS as a move_base plugin: its registration (named by pyproject.toml's
``simplebot_navigation.local_planners`` entry point), and the values of its namespace that follow move_base's one
speed setting (move_base/speed_profile.py). The ROS wrapper is named as text, so that this module imports no rclpy."""

from __future__ import annotations

from simplebot_navigation.mppi.config import MAX_DRIVE_ACCEL, MAX_DRIVE_TURN_RATE, MppiConfig
from simplebot_navigation.pluginlib import PluginSpec

MPPI_LOCAL_PLANNER = "mppi_local_planner/MPPILocalPlannerROS"
#: the simulated drives (sim/diff_drive.py): the lab's up to its top wheel speed, a Jackal's above it; their
#: top wheel speeds (m/s at the rim) and accelerations (m/s^2)
LAB_WHEEL_SPEED, LAB_ACCEL = 1.05, 1.75
JACKAL_WHEEL_SPEED, JACKAL_ACCEL = 2.0, 2.5
#: the Jackal drive's own yaw limits (rad/s, rad/s^2), below what its wheels allow
JACKAL_YAW_RATE, JACKAL_YAW_ACCEL = 4.0, 8.0
#: braking is planned at this share of what the drive can do, leaving the wheels grip to steer
BRAKING_SHARE = 0.85


def mppi_config(given):
    config = MppiConfig.from_params(given)
    return config, config.warnings


def speed_parameters(speed: float, wheel_separation: float | None = None) -> dict[str, float]:
    """MPPILocalPlannerROS's parameters for a top speed of ``speed`` m/s (within the speed profile's range) on the
    drive the simulator gives that speed: the speed limits; acceleration and braking at BRAKING_SHARE of what the
    drive's wheels do, and their speed and acceleration limits; with the robot's ``wheel_separation`` (m), the turn
    rate and turn acceleration its wheels allow (the Jackal's yaw limits above 1.05 m/s), which the wheel
    acceleration limit then shares with the speed; and the plan ahead as long as the horizon reaches."""
    lab = speed <= LAB_WHEEL_SPEED + 1e-9
    wheel, accel = (LAB_WHEEL_SPEED, LAB_ACCEL) if lab else (JACKAL_WHEEL_SPEED, JACKAL_ACCEL)
    horizon = MppiConfig().sampling.time_steps * MppiConfig().sampling.model_dt
    out = {"vx_max": speed, "vx_min": -max(0.2, 0.25 * speed), "ax_max": round(BRAKING_SHARE * accel, 3),
           "ax_min": -round(BRAKING_SHARE * accel, 3), "wheel_speed_max": wheel, "wheel_accel_max": accel,
           "prune_distance": round(max(3.5, speed * horizon + 1.0), 3)}
    if wheel_separation is not None:
        turn_rate, turn_accel = 2.0 * wheel / wheel_separation, 2.0 * accel / wheel_separation
        if not lab:
            turn_rate, turn_accel = min(turn_rate, JACKAL_YAW_RATE), min(turn_accel, JACKAL_YAW_ACCEL)
        out.update(wheel_separation=wheel_separation, wz_max=round(min(turn_rate, MAX_DRIVE_TURN_RATE), 3),
                   az_max=round(min(turn_accel, 4 * MAX_DRIVE_ACCEL), 3))
    return out


SPEC = PluginSpec(MPPI_LOCAL_PLANNER, "simplebot_navigation.ros.move_base.mppi_local_planner_ros:MPPILocalPlannerROS",
                  MppiConfig, mppi_config, speed_parameters)
