"""What makes a LaserScan unusable as a whole, one rule for every node that reads scans: the costmaps'
ObstacleLayer, the collision monitor and the obstacle tracker."""

from __future__ import annotations

import math

import numpy as np


def scan_problem(r: np.ndarray, angle_min, angle_increment, range_min, range_max,
                  sensor_pose) -> tuple[str, str] | None:
    """(field, why) a LaserScan cannot be projected at all, or None: NaN or inf in its geometry would project
    every beam to NaN, and a ranges list longer than one turn would wrap into a phantom ring."""
    if r.ndim != 1:
        return "ranges", f"ranges must be a flat list, got shape {r.shape}"
    for name, value in (("angle_min", angle_min), ("angle_increment", angle_increment),
                        ("range_min", range_min), ("range_max", range_max)):
        if not math.isfinite(value):
            return name, f"{name} is {value}"
    if not np.isfinite(sensor_pose).all():
        return "sensor pose", f"the sensor pose is not finite: {tuple(float(v) for v in sensor_pose)}"
    if not range_min < range_max:
        return "range_min", f"range_min {range_min:g} is not below range_max {range_max:g}"
    # One beam of slack: 360-degree scanners may repeat the first angle at the end.
    if (len(r) - 1) * abs(angle_increment) > math.tau + abs(angle_increment):
        return "ranges", (f"{len(r)} ranges at angle_increment {angle_increment:g} sweep more than one turn; "
                          "ranges does not match the scan's angles")
    return None
