"""Amcl as a whole: initial poses, when odometry moves the particles, determinism, and localization in the lab and
in a small flat: tracking from a wrong initial pose, KLD shrinking the cloud, a kidnapped robot found again."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplebot_navigation.localization import Amcl, AmclParams
from simplebot_navigation.localization.amcl_kernels import kld_limit
from simplebot_navigation.localization.clusters import bins_of
from simplebot_navigation.testing.amcl_scenes import Scanner, l_flat, lab_map, lab_scanner, occupancy_grid

#: odometry's errors: 2 % too long, 0.01 rad/s of yaw drift
ODOM_SCALE, ODOM_YAW_DRIFT = 1.02, 0.01


class Robot:
    """The true pose of a robot driven by (v, w), and the drifting odometry it reports."""

    def __init__(self, pose):
        self.true = np.array(pose, dtype=float)
        self.odom = np.zeros(3)

    def drive(self, v: float, w: float, dt: float = 0.1) -> None:
        self.true += [v * dt * math.cos(self.true[2]), v * dt * math.sin(self.true[2]), w * dt]
        self.odom += [ODOM_SCALE * v * dt * math.cos(self.odom[2]), ODOM_SCALE * v * dt * math.sin(self.odom[2]),
                      (w + ODOM_YAW_DRIFT) * dt]

    def error(self, amcl: Amcl) -> tuple[float, float]:
        """(position error in m, yaw error in degrees) of the estimate."""
        e = amcl.estimate()
        return (math.hypot(e.x - self.true[0], e.y - self.true[1]),
                math.degrees(abs(math.remainder(e.yaw - self.true[2], 2 * math.pi))))


def step(amcl: Amcl, robot: Robot, scanner: Scanner, rng, unmapped=()) -> bool:
    """One scan cycle: odometry, then both scans if the filter moved. True if it updated. ``unmapped``: circles
    (x, y, r) the scans see and the map lacks."""
    if not amcl.odometry_update(robot.odom):
        return False
    return amcl.sensor_update(scanner.scans(robot.true, rng, extra_circles=unmapped))


def corridor_drive(robot: Robot, k: int) -> None:
    """Weave along the lab's corridor (y = 0, heading +x) at 0.5 m/s."""
    yaw = math.remainder(robot.true[2], 2 * math.pi)
    robot.drive(0.5, 0.2 * math.sin(k / 10) - 0.8 * robot.true[1] - 1.0 * yaw)


def small_room() -> np.ndarray:
    data = np.full((60, 80), 0, dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    data[20:30, 40:45] = 100
    return data


def test_a_bad_initial_pose_is_refused_naming_the_field_and_changes_nothing():
    amcl = Amcl(AmclParams(max_particles=500), small_room(), 0.05)
    before = amcl.particles
    cases = [((math.nan, 1.0, 0.0, np.eye(3) * 0.1), "initial pose x"),
             ((1.0, math.inf, 0.0, np.eye(3) * 0.1), "initial pose y"),
             ((1.0, 1.0, -math.inf, np.eye(3) * 0.1), "initial pose yaw"),
             ((1.0, 1.0, 0.0, np.diag([0.1, -0.1, 0.1])), "covariance: must be positive definite"),
             ((1.0, 1.0, 0.0, np.diag([0.1, 0.1, 0.0])), "covariance: must be positive definite"),
             ((1.0, 1.0, 0.0, np.diag([0.1, math.nan, 0.1])), "covariance: must be finite"),
             ((1.0, 1.0, 0.0, [[0.1, 0.05, 0], [0, 0.1, 0], [0, 0, 0.1]]), "covariance: must be symmetric"),
             ((1.0, 1.0, 0.0, np.eye(2)), "covariance: expected 3x3")]
    for args, message in cases:
        with pytest.raises(ValueError, match=message):
            amcl.set_initial_pose(*args)
        np.testing.assert_array_equal(amcl.particles, before)
    amcl.set_initial_pose(1.0, 1.5, 0.3, np.diag([0.01, 0.02, 0.03]))
    assert amcl.particles.mean(axis=0) == pytest.approx([1.0, 1.5, 0.3], abs=0.02)
    assert amcl.particles.var(axis=0) == pytest.approx([0.01, 0.02, 0.03], rel=0.15)


@pytest.mark.parametrize("data, resolution, origin, message", [
    (np.zeros((4, 4)), 0.05, (0, 0, 0), "map data: expected int8"),
    (np.zeros(4, dtype=np.int8), 0.05, (0, 0, 0), r"map data: expected a non-empty \[height, width\]"),
    (np.full((4, 4), 300), 0.05, (0, 0, 0), "map data: expected int8"),
    (np.full((4, 4), 100, dtype=np.int8), 0.05, (0, 0, 0), "map data: no free cell"),
    (np.zeros((4, 4), dtype=np.int8), 0.0, (0, 0, 0), "map resolution"),
    (np.zeros((4, 4), dtype=np.int8), 0.05, (0, math.nan, 0), "map origin")])
def test_a_map_that_cannot_be_used_is_refused_naming_what(data, resolution, origin, message):
    with pytest.raises(ValueError, match=message):
        Amcl(AmclParams(), data, resolution, origin)


def test_odometry_moves_the_particles_once_x_y_or_yaw_alone_passes_its_threshold():
    amcl = Amcl(AmclParams(max_particles=300), small_room(), 0.05)
    amcl.set_initial_pose(1.5, 1.5, 0.0, np.diag([0.01, 0.01, 0.01]))
    assert not amcl.odometry_update((0.0, 0.0, 0.0))          # the first pose is only remembered
    assert amcl.sensor_update([])                             # ... and an update is due
    before = amcl.particles
    # 0.21 m away, but neither x nor y alone beyond update_min_d (0.2), and yaw below pi/6
    assert not amcl.odometry_update((0.15, 0.15, 0.5))
    assert not amcl.sensor_update([])
    np.testing.assert_array_equal(amcl.particles, before)
    assert amcl.odometry_update((0.21, 0.0, 0.0))
    moved = amcl.particles
    assert np.mean(moved[:, 0] - before[:, 0]) == pytest.approx(0.21, abs=0.01)
    assert amcl.odometry_update((0.25, 0.0, 0.0))             # an update is still due: small motion counts too
    assert np.mean(amcl.particles[:, 0] - moved[:, 0]) == pytest.approx(0.04, abs=0.01)
    assert amcl.sensor_update([])
    assert not amcl.odometry_update((0.26, 0.0, 0.0))
    amcl.request_nomotion_update()
    assert amcl.odometry_update((0.26, 0.0, 0.0)) and amcl.sensor_update([])


def test_the_same_seed_gives_the_same_particles_and_reset_starts_over():
    grid, resolution, origin = lab_map()
    runs = []
    for seed in (3, 3, 4):
        amcl = Amcl(AmclParams(seed=seed, max_particles=1000), grid, resolution, origin)
        fresh = amcl.particles
        amcl.set_initial_pose(-9.0, 0.2, 0.1, np.diag([0.1, 0.1, 0.05]))
        robot, rng = Robot((-9.0, 0.0, 0.0)), np.random.default_rng(0)
        for k in range(30):
            corridor_drive(robot, k)
            step(amcl, robot, lab_scanner(), rng)
        runs.append(amcl.particles)
        amcl.reset()
        np.testing.assert_array_equal(amcl.particles, fresh)
    np.testing.assert_array_equal(runs[0], runs[1])
    assert runs[0].shape != runs[2].shape or not np.array_equal(runs[0], runs[2])


#: the meeting room north of the corridor: a loop round its table and chairs, two people standing in it
ROOM_CENTRE, ROOM_RADIUS = (0.0, 5.5), 2.6
PEOPLE = ((-2.0, 3.0, 0.25), (2.0, 8.0, 0.25))


def room_loop(robot: Robot) -> None:
    robot.drive(0.5, 0.5 / ROOM_RADIUS)


@pytest.mark.parametrize("config, worst", [
    pytest.param(dict(laser_model_type="likelihood_field", laser_max_beams=60, laser_sigma_hit=0.1, odom_alpha1=0.5,
                      odom_alpha2=0.5, odom_alpha3=0.5, odom_alpha4=0.5), (0.08, 3.0), id="likelihood_field"),
    pytest.param(dict(laser_model_type="likelihood_field_prob", laser_max_beams=60), (0.05, 2.0),
                 id="likelihood_field_prob")])
def test_from_half_a_metre_and_20_degrees_off_it_tracks_the_robot_to_5_cm_and_2_degrees(config, worst):
    """One lap round the meeting room's table with drifting odometry, two people the map does not have standing
    by. amcl's likelihood_field sums the cubes of the beams' likelihoods, a flat peak: its worst error is allowed
    more than the product model's."""
    grid, resolution, origin = lab_map()
    amcl = Amcl(AmclParams(**config), grid, resolution, origin)
    start = (ROOM_CENTRE[0] + ROOM_RADIUS, ROOM_CENTRE[1], math.pi / 2)
    robot, rng = Robot(start), np.random.default_rng(7)
    amcl.set_initial_pose(start[0] + 0.4, start[1] - 0.3, start[2] + math.radians(20), np.diag([0.25, 0.25, 0.07]))
    assert robot.error(amcl)[0] == pytest.approx(0.5, abs=0.05)
    errors = []
    for _ in range(330):
        room_loop(robot)
        if step(amcl, robot, lab_scanner(), rng, PEOPLE):
            errors.append(robot.error(amcl))
    settled = np.array(errors[len(errors) // 2:])         # the second half of the lap
    assert np.median(settled[:, 0]) <= 0.05 and np.median(settled[:, 1]) <= 2.0
    assert settled[:, 0].max() <= worst[0] and settled[:, 1].max() <= worst[1]


def test_kld_shrinks_the_cloud_as_it_converges():
    grid, resolution, origin = lab_map()
    params = AmclParams(resample_interval=1)
    amcl = Amcl(params, grid, resolution, origin)
    robot, rng = Robot((-9.0, 0.0, 0.0)), np.random.default_rng(8)
    amcl.set_initial_pose(-9.0, 0.0, 0.0, np.diag([0.25, 0.25, 0.07]))
    counts = []
    for k in range(200):
        corridor_drive(robot, k)
        if step(amcl, robot, lab_scanner(), rng):
            bins = len(np.unique(bins_of(amcl.particles), axis=0))
            limit = kld_limit(bins, params.min_particles, params.max_particles, params.kld_err, params.kld_z)
            if bins > 2:
                assert len(amcl.particles) == min(limit + 1, params.max_particles)
            else:      # amcl asks for max_particles while one bin is filled: a second bin may come late
                assert len(amcl.particles) >= min(limit + 1, params.max_particles)
            counts.append(len(amcl.particles))
    assert counts[0] > 0.5 * params.max_particles
    assert np.median(counts[-20:]) < 0.1 * params.max_particles


def test_a_kidnapped_robot_is_found_again_by_global_localization():
    world = l_flat()
    grid, resolution, origin = occupancy_grid(world)
    scanner, rng = Scanner(world), np.random.default_rng(9)
    amcl = Amcl(AmclParams(), grid, resolution, origin)
    robot = Robot((8.0, 1.5, math.pi / 2))
    amcl.set_initial_pose(8.0, 1.5, math.pi / 2, np.diag([0.01, 0.01, 0.01]))

    def loop(centre, radius, updates):
        """Drive circles of ``radius`` round ``centre`` (the robot starts on one) for this many filter updates."""
        done = 0
        while done < updates:
            robot.drive(0.5, 0.5 / radius)
            done += step(amcl, robot, scanner, rng)

    loop((6.8, 1.5), 1.2, 20)
    assert robot.error(amcl)[0] < 0.1
    robot.true = np.array([3.0 + 1.2, 6.5, math.pi / 2])        # carried to the flat's other arm
    loop((3.0, 6.5), 1.2, 5)
    assert robot.error(amcl)[0] > 2.0, "the filter should not have noticed yet"
    amcl.global_localization()
    assert len(amcl.particles) == amcl.params.max_particles
    loop((3.0, 6.5), 1.2, 60)
    position, yaw = robot.error(amcl)
    assert position < 0.1 and yaw < 3.0
