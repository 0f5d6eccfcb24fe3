"""Small scenes for the TEB tests: lab parameters, rolling local costmaps, a unicycle robot."""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.planner import TebLocalPlanner

RES = 0.05
LAB_TWO_CIRCLES = {"type": "two_circles", "front_offset": 0.2, "front_radius": 0.2,
                   "rear_offset": 0.2, "rear_radius": 0.2}
LAB_PARAMS = {"odom_topic": "/odom", "map_frame": "/odom", "footprint_model": LAB_TWO_CIRCLES}
LAB_FOOTPRINT = np.array([[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]])
LAB_PADDED_FOOTPRINT = LAB_FOOTPRINT + np.sign(LAB_FOOTPRINT) * 0.03
PERIOD = 0.1


def lab_planner(**overrides) -> TebLocalPlanner:
    return TebLocalPlanner(TebConfig.from_params({**LAB_PARAMS, **overrides}), LAB_PADDED_FOOTPRINT, PERIOD)


def straight_plan(x0: float, x1: float, y: float = 0.0) -> np.ndarray:
    xs = np.arange(x0, x1 + 1e-9, RES)
    return np.column_stack([xs, np.full_like(xs, y), np.zeros_like(xs)])


def box_cells(cx: float, cy: float, half_x: float, half_y: float) -> np.ndarray:
    """World centres of the grid cells (cells aligned to multiples of RES) whose centre lies in
    the axis-aligned box."""
    kx = np.arange(math.ceil((cx - half_x) / RES - 0.5 - 1e-9), math.floor((cx + half_x) / RES - 0.5 + 1e-9) + 1)
    ky = np.arange(math.ceil((cy - half_y) / RES - 0.5 - 1e-9), math.floor((cy + half_y) / RES - 0.5 + 1e-9) + 1)
    gx, gy = np.meshgrid((kx + 0.5) * RES, (ky + 0.5) * RES)
    return np.column_stack([gx.ravel(), gy.ravel()])


def rolling_costmap(x: float, y: float, lethal_points: np.ndarray, size_m: float = 5.0) -> Costmap2D:
    """A local costmap centred on (x, y), with the cells containing the given points lethal."""
    cells = int(round(size_m / RES))
    ox = math.floor((x - size_m / 2) / RES) * RES
    oy = math.floor((y - size_m / 2) / RES) * RES
    cm = Costmap2D(cells, cells, RES, ox, oy)
    if len(lethal_points):
        mx, my, ok = cm.world_to_map_array(lethal_points[:, 0], lethal_points[:, 1])
        cm.costmap[my[ok], mx[ok]] = LETHAL_OBSTACLE
    return cm


def unicycle_step(pose: np.ndarray, v: float, omega: float, dt: float = PERIOD) -> np.ndarray:
    """Exact arc integration of constant (v, omega) over dt."""
    x, y, th = pose
    if abs(omega) < 1e-9:
        return np.array([x + v * dt * math.cos(th), y + v * dt * math.sin(th), th])
    r = v / omega
    th1 = th + omega * dt
    return np.array([x + r * (math.sin(th1) - math.sin(th)), y - r * (math.cos(th1) - math.cos(th)),
                     math.atan2(math.sin(th1), math.cos(th1))])


def footprint_hits(pose, footprint: np.ndarray, points: np.ndarray) -> bool:
    """True if any point lies inside the robot-centred rectangular footprint placed at pose."""
    if len(points) == 0:
        return False
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rel = points - np.asarray(pose[:2])
    local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])
    half = np.abs(footprint).max(axis=0)
    return bool(np.any((np.abs(local[:, 0]) <= half[0]) & (np.abs(local[:, 1]) <= half[1])))


def lab_door_scene() -> tuple[np.ndarray, np.ndarray]:
    """The lab's corridor (walls at y = +-1.25) with a 1.2 m door at x = 1.5, and a plan (x, y, yaw) from
    the origin along the corridor, round a 0.6 m arc and up through the door: (wall cells, plan)."""
    walls = np.vstack([box_cells(-2.0, 1.25, 2.9, 0.03), box_cells(4.0, 1.25, 1.9, 0.03),
                       box_cells(1.0, -1.25, 5.0, 0.03)])
    a = np.linspace(-math.pi / 2, 0.0, 19)
    path = np.vstack([np.column_stack([np.arange(0.0, 0.9, RES), np.zeros(18)]),
                      np.column_stack([0.9 + 0.6 * np.cos(a), 0.6 + 0.6 * np.sin(a)])[1:],
                      np.column_stack([np.full(40, 1.5), 0.6 + RES * np.arange(1, 41)])])
    yaw = np.arctan2(np.gradient(path[:, 1]), np.gradient(path[:, 0]))
    return walls, np.column_stack([path, yaw])
