"""mppi_local_planner/MPPILocalPlannerROS as a move_base plugin: its registration (named by pyproject.toml's
``simplebot_navigation.local_planners`` entry point), and the values of its namespace that follow move_base's one
speed setting (move_base/speed_profile.py). The ROS wrapper is named as text, so that this module imports no rclpy."""

from __future__ import annotations

from simplebot_navigation.mppi.config import MppiConfig
from simplebot_navigation.pluginlib import PluginSpec

MPPI_LOCAL_PLANNER = "mppi_local_planner/MPPILocalPlannerROS"
#: the simulated drives (sim/diff_drive.py): the lab's up to its top wheel speed, a Jackal's above it; their
#: top wheel speeds (m/s at the rim) and accelerations (m/s^2)
LAB_WHEEL_SPEED, LAB_ACCEL = 1.05, 1.75
JACKAL_WHEEL_SPEED, JACKAL_ACCEL = 2.0, 2.5
#: braking is planned at this share of what the drive can do, leaving the wheels grip to steer
BRAKING_SHARE = 0.85


def mppi_config(given):
    config = MppiConfig.from_params(given)
    return config, config.warnings


def speed_parameters(speed: float) -> dict[str, float]:
    """MPPILocalPlannerROS's parameters for a top speed of ``speed`` m/s (within the speed profile's range): the
    speed limits, acceleration within a second as for TEB, braking and the wheel limit of the drive the simulator
    gives that speed, and the plan ahead as long as the horizon reaches."""
    lab = speed <= LAB_WHEEL_SPEED + 1e-9
    wheel, accel = (LAB_WHEEL_SPEED, LAB_ACCEL) if lab else (JACKAL_WHEEL_SPEED, JACKAL_ACCEL)
    horizon = MppiConfig().sampling.time_steps * MppiConfig().sampling.model_dt
    return {"vx_max": speed, "vx_min": -max(0.2, 0.25 * speed), "ax_max": max(0.5, speed),
            "ax_min": -round(BRAKING_SHARE * accel, 3), "wheel_speed_max": wheel,
            "prune_distance": round(max(3.5, speed * horizon + 1.0), 3)}


SPEC = PluginSpec(MPPI_LOCAL_PLANNER, "simplebot_navigation.ros.move_base.mppi_local_planner_ros:MPPILocalPlannerROS",
                  MppiConfig, mppi_config, speed_parameters)
