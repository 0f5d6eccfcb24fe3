"""Synthetic lidar scans of moving cylinders and walls, with their ground truth, for the tracker's tests and bench.

The robot's two lidars (mounts and beam geometry from simplebot_description) are ray-cast against circles and
line segments in the world frame; ranges get Gaussian noise, misses are +inf.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from simplebot_description.robot import robot_description
from simplebot_navigation.perception import Scan


@dataclass(frozen=True)
class Cylinder:
    """A round obstacle starting at `start`, moving at `velocity`, its heading turning at `turn_rate`."""
    radius: float
    start: tuple[float, float]
    velocity: tuple[float, float] = (0.0, 0.0)
    turn_rate: float = 0.0

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(position, velocity) at time t."""
        v = np.asarray(self.velocity, dtype=float)
        p0 = np.asarray(self.start, dtype=float)
        w = self.turn_rate
        if abs(w) < 1e-12:
            return p0 + v * t, v
        c, s = math.cos(w * t), math.sin(w * t)
        rotated = np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])
        # integral of the rotating velocity: (R(wt) - I) J^-1 v / w, with J the quarter turn
        offset = np.array([s * v[0] - (1 - c) * v[1], (1 - c) * v[0] + s * v[1]]) / w
        return p0 + offset, rotated


@functools.cache
def lidars() -> tuple[tuple[tuple[float, float, float], object], ...]:
    """((x, y, yaw) mount in base_link, ScanParams) of the robot's lidars."""
    description = robot_description()
    return tuple(((pose[0], pose[1], pose[3]), description.scans[frame])
                 for frame, pose in description.laser_poses.items())


def ray_ranges(origin, angles: np.ndarray, circles: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance along each ray to the nearest circle (K, 3: x, y, r) or segment (M, 4: x0, y0, x1, y1); inf if none."""
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    best = np.full(len(angles), np.inf)
    if len(circles):
        oc = circles[:, :2] - origin                                    # (K, 2)
        along = d @ oc.T                                                # (N, K)
        miss2 = np.einsum("kj,kj->k", oc, oc)[None, :] - along ** 2
        half = np.sqrt(np.maximum(circles[None, :, 2] ** 2 - miss2, 0.0))
        t = np.where(miss2 <= circles[None, :, 2] ** 2, along - half, np.inf)
        best = np.minimum(best, np.where(t > 0, t, np.inf).min(axis=1))
    if len(segments):
        a = segments[:, :2] - origin
        e = segments[:, 2:] - segments[:, :2]
        denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (a[None, :, 0] * e[None, :, 1] - a[None, :, 1] * e[None, :, 0]) / denom
            u = (a[None, :, 0] * d[:, None, 1] - a[None, :, 1] * d[:, None, 0]) / denom
        t = np.where((np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    return best


def scans_at(robot_pose, t: float, cylinders=(), segments=(), noise: float = 0.01, rng=None) -> list[Scan]:
    """Both lidars' scans at time t from a robot at (x, y, yaw), in the world frame."""
    rng = rng or np.random.default_rng(0)
    circles = np.array([[*c.state(t)[0], c.radius] for c in cylinders]).reshape(-1, 3)
    walls = np.asarray(segments, dtype=float).reshape(-1, 4)
    x, y, yaw = robot_pose
    out = []
    for (mx, my, myaw), params in lidars():
        origin = np.array([x + mx * math.cos(yaw) - my * math.sin(yaw), y + mx * math.sin(yaw) + my * math.cos(yaw)])
        increment = (params.angle_max - params.angle_min) / (params.samples - 1)
        scan = Scan.from_laser(np.zeros(params.samples), params.angle_min, increment, params.range_min,
                               params.range_max, *origin, yaw + myaw)
        ranges = ray_ranges(origin, scan.angles, circles, walls)
        ranges = ranges + rng.normal(0.0, noise, len(ranges))
        scan.ranges = np.where(ranges < params.range_max, ranges, np.inf)
        out.append(scan)
    return out


def truth_at(t: float, cylinders) -> tuple[np.ndarray, np.ndarray]:
    """(positions (K, 2), velocities (K, 2)) of the cylinders at time t."""
    states = [c.state(t) for c in cylinders]
    return np.array([p for p, _ in states]).reshape(-1, 2), np.array([v for _, v in states]).reshape(-1, 2)
