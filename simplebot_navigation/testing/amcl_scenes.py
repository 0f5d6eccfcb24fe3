"""The lab as amcl's tests and bench see it: an occupancy grid of the lab world and the robot's two scans in it.

The grid is the world's exported map (sim/map_export.py): cells an obstacle overlaps are occupied (100), the free
space reachable from the start is free (0), the rest (outside the outer walls) unknown (-1). Scans are ray-cast
against the world's true shapes, not the grid, with Gaussian range noise, so the map is as imperfect as a real
one: the grid's walls are whole cells.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from simplebot_navigation.localization import RangeScan
from simplebot_navigation.sim.map_export import export_map
from simplebot_navigation.sim.world import Cylinder, World, world_from_dict
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.testing.lidar_scenes import lidars, ray_ranges

LAB_RESOLUTION = 0.05


def occupancy_grid(world: World, resolution: float = LAB_RESOLUTION) -> tuple[np.ndarray, float, tuple]:
    """(int8 grid [height, width], resolution, origin (x, y, yaw)) of a world, as map_server serves it
    (sim/map_export.py: unknown where the robot cannot reach)."""
    exported = export_map(world, resolution)
    return exported.data, exported.resolution, exported.origin


#: an L-shaped flat with furniture of different shapes: no two places in it look alike to the lidars
L_FLAT = {
    "name": "l_flat",
    "walls": [{"from": a, "to": b, "thickness": 0.15} for a, b in (
        ([0, 0], [10, 0]), ([10, 0], [10, 5]), ([10, 5], [6, 5]), ([6, 5], [6, 9]), ([6, 9], [0, 9]), ([0, 9], [0, 0]),
        ([3, 4], [5, 4]))],
    "boxes": [{"center": [2.0, 2.0], "size": [1.5, 0.8]}, {"center": [8.0, 3.5], "size": [0.6, 1.8], "yaw": 0.4},
              {"center": [4.5, 8.4], "size": [2.0, 0.6]}],
    "cylinders": [{"center": [4.0, 6.5], "radius": 0.3}, {"center": [1.5, 7.5], "radius": 0.5},
                  {"center": [7.5, 1.0], "radius": 0.2}],
    "start": {"x": 5.0, "y": 2.0, "yaw": 0.0},
}


@functools.cache
def l_flat() -> World:
    return world_from_dict(L_FLAT, source="l_flat")


@functools.cache
def lab_world() -> World:
    return load_world("lab")


@functools.cache
def lab_map() -> tuple[np.ndarray, float, tuple]:
    """The lab's occupancy grid at 5 cm (computed once per process)."""
    return occupancy_grid(lab_world())


def outlines(world: World) -> tuple[np.ndarray, np.ndarray]:
    """(circles (K, 3) x, y, r; segments (M, 4)) of the world's static obstacles, for ray casting."""
    circles, segments = [], []
    for _, shape in world.obstacles():
        if isinstance(shape, Cylinder):
            circles.append((*shape.center, shape.radius))
            continue
        corners = shape.corners()
        segments += [(*corners[i], *corners[(i + 1) % 4]) for i in range(4)]
    return np.array(circles).reshape(-1, 3), np.array(segments).reshape(-1, 4)


class Scanner:
    """The robot's two lidars in one world: scans ray-cast against its true shapes."""

    def __init__(self, world: World):
        self.circles, self.segments = outlines(world)

    def scans(self, pose, rng: np.random.Generator, noise: float = 0.02, extra_circles=()) -> list[RangeScan]:
        """Both lidars' scans from a robot at ``pose`` (x, y, yaw), ranges with Gaussian ``noise`` (m), no return
        beyond range_max (+inf). ``extra_circles`` (x, y, r) are things the map lacks (people, moved chairs)."""
        circles = self.circles
        if len(extra_circles):
            circles = np.vstack((circles, np.asarray(extra_circles, dtype=float).reshape(-1, 3)))
        x, y, yaw = pose
        out = []
        for (mx, my, myaw), params in lidars():
            origin = np.array([x + mx * math.cos(yaw) - my * math.sin(yaw),
                               y + mx * math.sin(yaw) + my * math.cos(yaw)])
            bearings = params.angle_min + params.angle_increment * np.arange(params.samples)
            ranges = ray_ranges(origin, yaw + myaw + bearings, circles, self.segments)
            ranges = ranges + rng.normal(0.0, noise, len(ranges))
            ranges = np.where(ranges <= params.range_max, ranges, np.inf)
            out.append(RangeScan(ranges.astype(np.float32), params.angle_min, params.angle_increment,
                                 params.range_min, params.range_max, (mx, my, myaw)))
        return out


@functools.cache
def lab_scanner() -> Scanner:
    return Scanner(lab_world())
