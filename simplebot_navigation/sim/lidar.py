"""Planar lidar beams and the LaserScan they produce.

Beams are laid out once in base_link (numpy) from the URDF's sensor blocks; at scan time they are
moved to the world with the robot's pose and cast in one batch. Range conventions follow REP-117:
+inf for no return within range_max, -inf for a return closer than range_min.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplebot_description import RobotDescription, ScanParams


@dataclass(frozen=True)
class LaserScanData:
    """One sensor_msgs/LaserScan worth of data (all beams taken at ``stamp``)."""

    frame: str
    topic: str
    stamp: float
    angle_min: float
    angle_max: float
    angle_increment: float
    time_increment: float
    scan_time: float
    range_min: float
    range_max: float
    ranges: np.ndarray  # float32


class LidarRig:
    """All lidars of the robot: beam origins and end points in base_link, and range conversion."""

    def __init__(self, description: RobotDescription, noise_std: float = 0.0,
                 rng: np.random.Generator | None = None):
        if not noise_std >= 0:
            raise ValueError(f"lidar range noise std must be >= 0, got {noise_std!r}")
        self.noise_std = noise_std
        self._rng = rng if rng is not None else np.random.default_rng(0)
        self.sensors: list[ScanParams] = list(description.scans.values())
        origins, ends, self.slices = [], [], []
        start = 0
        for sensor in self.sensors:
            x, y, z, yaw = description.laser_poses[sensor.frame]
            angles = yaw + sensor.angle_min + sensor.angle_increment * np.arange(sensor.samples)
            origin = np.array([x, y, z])
            direction = np.column_stack((np.cos(angles), np.sin(angles), np.zeros(sensor.samples)))
            origins.append(np.broadcast_to(origin, (sensor.samples, 3)))
            ends.append(origin + sensor.range_max * direction)
            self.slices.append(slice(start, start + sensor.samples))
            start += sensor.samples
        self._origins = np.vstack(origins)
        self._ends = np.vstack(ends)

    def rays(self, indices, position, rotation) -> tuple[np.ndarray, np.ndarray]:
        """World-frame (from, to) of the beams of the given sensors, for base_link at the pose."""
        rows = np.r_[tuple(self.slices[i] for i in indices)]
        return self._origins[rows] @ rotation.T + position, self._ends[rows] @ rotation.T + position

    def scans(self, indices, fractions: np.ndarray, hit: np.ndarray, stamp: float) -> list[LaserScanData]:
        """Turn hit fractions of the cast rays (in ``rays`` order) into one scan per sensor."""
        out = []
        offset = 0
        for i in indices:
            sensor = self.sensors[i]
            n = sensor.samples
            ranges = np.where(hit[offset:offset + n], fractions[offset:offset + n] * sensor.range_max, np.inf)
            offset += n
            if self.noise_std:
                finite = np.isfinite(ranges)
                ranges[finite] += self._rng.normal(0.0, self.noise_std, int(finite.sum()))
                ranges[ranges > sensor.range_max] = np.inf
            ranges[ranges < sensor.range_min] = -np.inf
            out.append(LaserScanData(
                frame=sensor.frame, topic=sensor.topic, stamp=stamp,
                angle_min=sensor.angle_min, angle_max=sensor.angle_max,
                angle_increment=sensor.angle_increment, time_increment=0.0,
                scan_time=1.0 / sensor.update_rate, range_min=sensor.range_min,
                range_max=sensor.range_max, ranges=ranges.astype(np.float32)))
        return out
