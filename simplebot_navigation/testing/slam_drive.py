"""SLAM on a scripted drive, without ROS: the robot follows a route through a world in the simulator, with drifting
encoders, and every scan goes to a slam.Mapper; the map and the trajectory are then judged against the world's
truth (bench/slam.py, tests/slam/test_mapper_drive.py).

The map frame is the world's: the mapper is told that the robot starts at the world's start (map_start_pose), as
the launch does, so map, truth and exported map compare cell for cell.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field

import numpy as np
import yaml
from scipy import ndimage

from simplebot_description import robot_description
from simplebot_navigation.maps.map_io import OccupancyMap
from simplebot_navigation.paths import package_share
from simplebot_navigation.sim.diff_drive import OdomNoise
from simplebot_navigation.sim.map_export import export_map
from simplebot_navigation.sim.simulator import SimplebotSim
from simplebot_navigation.sim.world import Pose2D, World
from simplebot_navigation.slam.mapper import BEAM_MODEL, Mapper
from simplebot_navigation.slam.occupancy import render
from simplebot_navigation.slam.params import SlamParams
from simplebot_navigation.slam.scan_points import ScanPoints, scan_points
from simplebot_navigation.testing.scripted_drive import PathFollower, planned_route

#: the launch's encoder errors (launch_py/simulator.py): 1 % scale per wheel, 2 % speed noise
ENCODER_NOISE = OdomNoise(scale_std=0.01, speed_std=0.02)
#: a map cell this many cells from the truth's still counts (the issue's 1-cell tolerance)
TOLERANCE_CELLS = 1
#: an occupied blob of the map at least this long and further than the tolerance from every true wall is a doubled
#: wall (a wall seen twice, shifted: what a map without loop closure shows after a loop)
DOUBLED_WALL_CELLS = 10


@dataclass
class SlamRun:
    mapper: Mapper
    truth: list[tuple[float, float, float]] = field(default_factory=list)       # at each node
    odometry: list[tuple[float, float, float]] = field(default_factory=list)    # in the world frame, each node
    add_scan_s: list[float] = field(default_factory=list)                       # wall time of each add_scan
    sim_time: float = 0.0
    reached: bool = False
    final_odometry: tuple[float, float, float] = (0.0, 0.0, 0.0)                # in the odom frame, at the end
    final_truth: tuple[float, float, float] = (0.0, 0.0, 0.0)


def configured_params(**overrides) -> SlamParams:
    """config/slam/slam.yaml, as the launch gives it to the slam node, with ``overrides``."""
    path = os.path.join(package_share("simplebot_navigation"), "config", "slam", "slam.yaml")
    with open(path, encoding="utf-8") as f:
        return SlamParams.from_params({**yaml.safe_load(f), **overrides})


def drive(world: World, goals: list[Pose2D], params: SlamParams, speed: float = 1.0, seed: int = 0,
          odom_noise: OdomNoise = ENCODER_NOISE, time_limit_s: float = 1200.0, mapper: Mapper | None = None,
          start: tuple[float, float, float] | None = None) -> SlamRun:
    """Drive from the world's start through ``goals`` (route planned on the true map), mapping as it goes: into
    ``mapper`` (a new one by default), which is told the robot starts at ``start`` (default: the world's start)."""
    description = robot_description("box")
    follower = PathFollower(planned_route(world, goals, description.inscribed_radius), speed)
    sensors = {frame: (p[0], p[1], p[3]) for frame, p in description.laser_poses.items()}
    run = SlamRun(mapper if mapper is not None else Mapper(params))
    start = start or (world.start.x, world.start.y, world.start.yaw)
    with SimplebotSim(world, description, seed=seed, odom_noise=odom_noise) as sim:
        odom = sim.odometry()
        run.mapper.set_pose(start, (odom.x, odom.y, odom.yaw))
        while not follower.done and sim.sim_time < time_limit_s:
            truth = sim.ground_truth()
            sim.set_cmd_vel(*follower.command(truth.x, truth.y, truth.yaw))
            sim.step()
            scans = sim.due_scans()
            if scans:
                _map_scans(run, sim, scans, sensors, (world.start.x, world.start.y, world.start.yaw))
        odom, truth = sim.odometry(), sim.ground_truth()
        run.sim_time, run.reached = sim.sim_time, follower.done
        run.final_odometry, run.final_truth = (odom.x, odom.y, odom.yaw), (truth.x, truth.y, truth.yaw)
    return run


def _map_scans(run: SlamRun, sim: SimplebotSim, scans, sensors, start) -> None:
    p = run.mapper.params
    merged = ScanPoints.merged([scan_points(s.ranges, s.angle_min, s.angle_increment, max(s.range_min,
                                            p.min_laser_range), s.range_max, sensors[s.frame], p.max_laser_range)
                                for s in scans])
    odom, truth = sim.odometry(), sim.ground_truth()
    began = time.perf_counter()
    update = run.mapper.add_scan((odom.x, odom.y, odom.yaw), merged)
    run.add_scan_s.append(time.perf_counter() - began)
    if update.node is not None:
        run.truth.append((truth.x, truth.y, truth.yaw))
        c, s = math.cos(start[2]), math.sin(start[2])
        run.odometry.append((start[0] + c * odom.x - s * odom.y, start[1] + s * odom.x + c * odom.y,
                             math.remainder(start[2] + odom.yaw, math.tau)))


def trajectory_rmse(estimate, truth) -> float:
    """Absolute trajectory error: the RMS of the position errors (no alignment: both are in the world frame)."""
    estimate, truth = np.asarray(estimate)[:, :2], np.asarray(truth)[:, :2]
    return float(np.sqrt(np.mean(np.sum((estimate - truth) ** 2, axis=1))))


@dataclass(frozen=True)
class MapScore:
    precision: float     # the map's occupied cells within the tolerance of a true obstacle (the world's map)
    recall: float        # the walls the scans saw (drawn from the true poses), within the tolerance of the map's
    doubled_walls: int   # occupied blobs of the map away from every true obstacle


def map_score(built: OccupancyMap, world: World, run: SlamRun) -> MapScore:
    """The built map against the truth, cell for cell in world coordinates: precision against the world's exported
    map at the same resolution; recall against the map the same scans give at the true poses (what a perfect SLAM
    would draw: walls no scan saw, or that the world's map rasterises differently, are not held against it)."""
    truth = export_map(world, built.resolution)
    seen = render(run.truth, run.mapper.scans, built.resolution, hit_probability=BEAM_MODEL[0],
                  miss_probability=BEAM_MODEL[1]).occupancy_map()
    (occupied_truth, occupied_built), (occupied_seen, occupied_built_too) = (
        _aligned(truth, built), _aligned(seen, built))
    eight = np.ones((3, 3), bool)
    near_truth = ndimage.binary_dilation(occupied_truth, iterations=TOLERANCE_CELLS, structure=eight)
    near_built = ndimage.binary_dilation(occupied_built_too, iterations=TOLERANCE_CELLS, structure=eight)
    stray = occupied_built & ~near_truth
    labels, count = ndimage.label(stray, structure=eight)
    sizes = np.bincount(labels.ravel())[1:] if count else np.zeros(0, int)
    return MapScore(float((occupied_built & near_truth).sum() / max(occupied_built.sum(), 1)),
                    float((occupied_seen & near_built).sum() / max(occupied_seen.sum(), 1)),
                    int((sizes >= DOUBLED_WALL_CELLS).sum()))


def _aligned(first: OccupancyMap, second: OccupancyMap) -> tuple[np.ndarray, np.ndarray]:
    """The occupied cells of two maps of one resolution on one grid covering both."""
    res = first.resolution
    offsets = [(round(m.origin[0] / res), round(m.origin[1] / res)) for m in (first, second)]
    col0, row0 = min(o[0] for o in offsets), min(o[1] for o in offsets)
    cols = max(o[0] + m.width for o, m in zip(offsets, (first, second))) - col0
    rows = max(o[1] + m.height for o, m in zip(offsets, (first, second))) - row0

    def place(m: OccupancyMap, offset) -> np.ndarray:
        out = np.zeros((rows, cols), bool)
        out[offset[1] - row0:offset[1] - row0 + m.height, offset[0] - col0:offset[0] - col0 + m.width] = m.data == 100
        return out

    return place(first, offsets[0]), place(second, offsets[1])
