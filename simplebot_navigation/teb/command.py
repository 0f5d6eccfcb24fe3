"""The velocity command of a TEB control cycle (docs/reference.md §4.5 step 10): read off the
band's start, then held to the acceleration window and the velocity limits."""

from __future__ import annotations

import math

from simplebot_navigation.geometry import normalize_theta


def velocity_from_band(band, cfg):
    """Velocity between pose 0 and pose control_look_ahead_poses (fewer if their time exceeds
    dt_ref per pose), with the sign of the motion along the start heading."""
    if band is None or len(band.poses) < 2:
        return None
    trajectory = cfg.trajectory
    look = max(1, min(trajectory.control_look_ahead_poses,
                      len(band.poses) - 1 - trajectory.prevent_look_ahead_poses_near_goal))
    dt = 0.0
    for k in range(look):
        dt += band.time_diffs[k]
        if dt >= trajectory.dt_ref * look:
            look = k + 1
            break
    if not dt > 0:
        return None
    p0, p1 = band.poses[0], band.poses[look]
    d = p1[:2] - p0[:2]
    direction = d[0] * math.cos(p0[2]) + d[1] * math.sin(p0[2])
    v = math.copysign(1.0, direction) * math.hypot(*d) / dt if direction != 0 else 0.0
    omega = float(normalize_theta(p1[2] - p0[2])) / dt
    if not (math.isfinite(v) and math.isfinite(omega)):
        return None
    return v, omega


def saturate(v, omega, current, cfg, controller_period: float):
    """Acceleration window over one control period around the odometry velocity, then the
    velocity limits (they win if both cannot hold)."""
    robot = cfg.robot
    dv = robot.acc_lim_x * controller_period
    dw = robot.acc_lim_theta * controller_period
    v = min(max(v, current[0] - dv), current[0] + dv)
    omega = min(max(omega, current[1] - dw), current[1] + dw)
    backwards = robot.max_vel_x_backwards if robot.max_vel_x_backwards > 0 else robot.max_vel_x
    ratio_v = 1.0
    if v > robot.max_vel_x:
        ratio_v = robot.max_vel_x / v
    elif v < -backwards:
        ratio_v = -backwards / v
    ratio_w = abs(robot.max_vel_theta / omega) if abs(omega) > robot.max_vel_theta else 1.0
    if robot.use_proportional_saturation:
        ratio_v = ratio_w = min(ratio_v, ratio_w)
    return v * ratio_v, omega * ratio_w
