"""A small world of boxes seen by the lab's two Hokuyo scans (683 beams, ±120°, 0.2–5.6 m, 10 Hz)."""

from __future__ import annotations

import math

import numpy as np

BEAMS = 683
ANGLE_MIN = -2.0944
ANGLE_INCREMENT = 2 * 2.0944 / (BEAMS - 1)
RANGE_MIN, RANGE_MAX = 0.2, 5.6
LASERS = {"front_laser": (0.35, 0.0, 0.15, 0.0), "back_laser": (-0.35, 0.0, 0.15, math.pi)}

#: (xmin, ymin, xmax, ymax): a corridor wall, a few boxes and a pillar near the path
BOXES = np.array([
    [-3.0, 1.6, 8.0, 1.8],
    [1.5, -1.2, 1.9, -0.8],
    [3.0, 0.5, 3.3, 0.8],
    [-2.0, -2.5, -1.5, -2.0],
    [5.0, -1.5, 5.6, -0.2],
])


def scan_ranges(sensor_x: float, sensor_y: float, sensor_yaw: float, boxes=BOXES) -> np.ndarray:
    """Ranges of the nearest box along each beam; +inf when nothing is hit within RANGE_MAX."""
    angles = sensor_yaw + ANGLE_MIN + ANGLE_INCREMENT * np.arange(BEAMS)
    dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        tx1, tx2 = (boxes[:, 0] - sensor_x) / dx, (boxes[:, 2] - sensor_x) / dx
        ty1, ty2 = (boxes[:, 1] - sensor_y) / dy, (boxes[:, 3] - sensor_y) / dy
    t_near = np.maximum(np.minimum(tx1, tx2), np.minimum(ty1, ty2))
    t_far = np.minimum(np.maximum(tx1, tx2), np.maximum(ty1, ty2))
    hit = (t_far >= t_near) & (t_near > 0)
    t = np.where(hit, t_near, np.inf).min(axis=1)
    return np.where(t < RANGE_MAX, t, np.inf)


def laser_pose(robot_x: float, robot_y: float, robot_yaw: float, laser: str):
    lx, ly, lz, lyaw = LASERS[laser]
    c, s = math.cos(robot_yaw), math.sin(robot_yaw)
    return (robot_x + c * lx - s * ly, robot_y + s * lx + c * ly, lz, robot_yaw + lyaw)


def robot_path(steps: int):
    """Poses creeping forward and turning a little, about what 10 Hz updates see at 0.3 m/s."""
    for k in range(steps):
        yield 0.03 * k, 0.005 * k, 0.01 * k
