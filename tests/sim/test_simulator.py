"""SimplebotSim: scan geometry, driving, limits, odometry, contacts, determinism."""

import math

import numpy as np
import pytest

from simplebot_description import robot_description
from simplebot_navigation.sim import (
    Cylinder, DiffDriveParams, OdomNoise, Pose2D, SimplebotSim, Wall, World, load_world)

BOX = robot_description("box")
ROUND = robot_description("round")
DRIVE = DiffDriveParams()
# Top speed and acceleration of the body, from the wheel limits.
MAX_ACCEL = DRIVE.max_wheel_accel * BOX.wheel_radius          # 1.75 m/s^2
MAX_SPEED = DRIVE.max_wheel_speed * BOX.wheel_radius          # 1.05 m/s
MAX_ALPHA = 2 * MAX_ACCEL / BOX.wheel_separation              # 7 rad/s^2
CENTRE = 341  # beam at angle 0 of 683 over [-2.0944, 2.0944]


def wall_ahead(distance, thickness=0.1, half_length=3.0):
    """A world whose wall surface is `distance` in front of base_link at the start."""
    x = distance + thickness / 2
    return World("wall", walls=(Wall((x, -half_length), (x, half_length), thickness),))


def beam_angles(scan):
    return scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))


def first_scans(sim):
    sim.step_until(0.1)
    return {s.frame: s for s in sim.due_scans()}


def drive(sim, v, w, seconds, rate=10.0):
    """Send (v, w) at `rate` Hz, as a controller would, for `seconds` of sim time."""
    end = sim.sim_time + seconds
    while sim.sim_time < end - 1e-9:
        sim.set_cmd_vel(v, w)
        sim.step_until(min(end, sim.sim_time + 1.0 / rate))


@pytest.fixture
def make_sim():
    sims = []

    def make(world, description=BOX, **kwargs):
        sims.append(SimplebotSim(world, description, **kwargs))
        return sims[-1]

    yield make
    for sim in sims:
        sim.close()


# -- lidars ------------------------------------------------------------------------------------

@pytest.mark.parametrize("description", [BOX, ROUND], ids=["box", "round"])
def test_front_scan_of_a_wall_2m_ahead(make_sim, description):
    scan = first_scans(make_sim(wall_ahead(2.0), description))["front_laser_link"]
    laser_x = description.laser_poses["front_laser_link"][0]
    assert scan.ranges[CENTRE] == pytest.approx(2.0 - laser_x, abs=0.01)
    # Every beam that reaches the wall reads the distance along its direction.
    angles = beam_angles(scan)
    expected = (2.0 - laser_x) / np.cos(angles)
    on_wall = (np.abs(angles) < 1.2) & (np.abs(np.tan(angles) * (2.0 - laser_x)) < 2.9)
    np.testing.assert_allclose(scan.ranges[on_wall], expected[on_wall], atol=0.01)


def test_scan_header_fields(make_sim):
    scans = first_scans(make_sim(wall_ahead(2.0)))
    for frame, topic in (("front_laser_link", "front_laser/front_scan"), ("back_laser_link", "back_laser/back_scan")):
        s = scans[frame]
        assert (s.topic, s.stamp, s.time_increment, s.scan_time) == (topic, 0.1, 0.0, 0.1)
        assert (s.angle_min, s.angle_max, s.range_min, s.range_max) == (-2.0944, 2.0944, 0.2, 5.6)
        assert s.angle_increment == pytest.approx(2 * 2.0944 / 682)
        assert s.ranges.shape == (683,) and s.ranges.dtype == np.float32


def test_beams_beyond_range_max_are_inf(make_sim):
    scan = first_scans(make_sim(wall_ahead(2.0)))["front_laser_link"]
    angles = beam_angles(scan)
    too_far = (2.0 - 0.35) / np.cos(angles[np.abs(angles) < 1.5]) > 5.6 + 0.01
    assert too_far.any()
    assert np.all(np.isposinf(scan.ranges[np.abs(angles) < 1.5][too_far]))
    far_wall = first_scans(make_sim(wall_ahead(6.0)))["front_laser_link"]
    assert np.all(np.isposinf(far_wall.ranges))


def test_return_closer_than_range_min_is_minus_inf(make_sim):
    # Wall 0.15 m from the front laser (0.05 m from the chassis): too close to measure (REP 117).
    scan = first_scans(make_sim(wall_ahead(0.5)))["front_laser_link"]
    assert scan.ranges[CENTRE] == -np.inf


def test_back_scan_sees_what_is_behind(make_sim):
    # A pole behind and to the right of the robot (world frame). The back laser looks backwards
    # (yaw pi), so world direction -135 deg from it is beam angle +45 deg.
    pole = Cylinder((-1.35, -1.0), 0.1)
    world = World("pole", walls=(Wall((2.05, -3), (2.05, 3)),), cylinders=(pole,))
    scans = first_scans(make_sim(world))
    back = scans["back_laser_link"]
    beam = int(round((math.pi / 4 - back.angle_min) / back.angle_increment))
    assert back.ranges[beam] == pytest.approx(math.sqrt(2) - 0.1, abs=0.01)
    assert np.isfinite(back.ranges).sum() < 30  # the pole, nothing else
    assert np.all(np.isposinf(back.ranges[np.abs(beam_angles(back)) < 0.5]))
    assert np.isposinf(scans["front_laser_link"].ranges[beam_angles(back) > 2.0]).all()


@pytest.mark.parametrize("description", [BOX, ROUND], ids=["box", "round"])
def test_own_body_is_never_seen(make_sim, description):
    sim = make_sim(World("empty"), description)
    drive(sim, 0.3, 0.8, 2.0)
    scans = sim.due_scans()
    assert len(scans) == 40
    for scan in scans:
        assert np.all(np.isposinf(scan.ranges)), scan.frame


def test_scans_come_at_10_hz_from_both_lidars(make_sim):
    sim = make_sim(World("empty"))
    sim.step_until(1.0)
    scans = sim.due_scans()
    assert [(s.frame, round(s.stamp, 9)) for s in scans] == [
        (frame, round(0.1 * k, 9)) for k in range(1, 11) for frame in ("front_laser_link", "back_laser_link")]
    assert sim.due_scans() == []


def test_range_noise_is_seeded(make_sim):
    def centre_ranges(seed):
        sim = make_sim(wall_ahead(2.0), range_noise_std=0.02, seed=seed)
        return first_scans(sim)["front_laser_link"].ranges[300:380]

    a, b, c = centre_ranges(1), centre_ranges(1), centre_ranges(2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    clean = first_scans(make_sim(wall_ahead(2.0)))["front_laser_link"].ranges[300:380]
    assert 0.01 < np.std(a - clean) < 0.03


def test_lab_world_corridor_walls_are_seen(make_sim):
    sim = make_sim(load_world("lab"))
    front = first_scans(sim)["front_laser_link"]
    # The corridor walls' faces are 1.2 m either side of the start; the laser is on the centre line.
    assert np.min(front.ranges[np.isfinite(front.ranges)]) == pytest.approx(1.2, abs=0.01)


# -- driving -----------------------------------------------------------------------------------

def test_start_pose_is_the_world_start_and_the_odom_origin(make_sim):
    world = World("empty", start=Pose2D(1.0, -2.0, 0.5))
    sim = make_sim(world)
    gt, odom = sim.ground_truth(), sim.odometry()
    assert (gt.x, gt.y, gt.yaw) == pytest.approx((1.0, -2.0, 0.5), abs=1e-6)
    assert (gt.frame_id, odom.frame_id, odom.child_frame_id) == ("world", "odom", "base_link")
    assert (odom.x, odom.y, odom.yaw) == (0.0, 0.0, 0.0)
    drive(sim, 0.3, 0.0, 2.0)
    gt, odom = sim.ground_truth(), sim.odometry()
    # Odometry is the motion since the start, expressed in the start frame.
    c, s = math.cos(0.5), math.sin(0.5)
    assert (1.0 + c * odom.x - s * odom.y, -2.0 + s * odom.x + c * odom.y) == pytest.approx((gt.x, gt.y), abs=0.005)


def test_straight_at_0p3_for_5s(make_sim):
    sim = make_sim(World("empty"))
    drive(sim, 0.3, 0.0, 5.0)
    odom, gt = sim.odometry(), sim.ground_truth()
    assert odom.x == pytest.approx(1.5, abs=0.05)
    # Precisely: 1.5 m minus what the acceleration ramp costs, v^2 / (2 a).
    assert odom.x == pytest.approx(1.5 - 0.3 ** 2 / (2 * MAX_ACCEL), abs=0.005)
    assert abs(odom.y) < 0.01 and abs(odom.yaw) < 0.01
    assert (odom.vx, odom.vy, odom.wz) == pytest.approx((0.3, 0.0, 0.0), abs=0.003)
    assert (gt.x, gt.vx) == pytest.approx((odom.x, odom.vx), abs=0.005)


def test_turn_in_place_integrates_yaw(make_sim):
    sim = make_sim(World("empty"))
    drive(sim, 0.0, 0.5, 4.0)
    odom, gt = sim.odometry(), sim.ground_truth()
    expected = 0.5 * 4.0 - 0.5 ** 2 / (2 * MAX_ALPHA)
    assert odom.yaw == pytest.approx(expected, abs=0.01)
    assert gt.yaw == pytest.approx(expected, abs=0.02)
    assert math.hypot(gt.x, gt.y) < 0.01 and math.hypot(odom.x, odom.y) < 0.01
    assert odom.wz == pytest.approx(0.5, abs=0.005)


def test_yaw_wraps_past_pi(make_sim):
    sim = make_sim(World("empty"))
    drive(sim, 0.0, -1.0, 4.0)
    expected = math.remainder(-4.0 + 1.0 / (2 * MAX_ALPHA), math.tau)
    assert sim.odometry().yaw == pytest.approx(expected, abs=0.02)
    assert sim.ground_truth().yaw == pytest.approx(expected, abs=0.03)


def test_acceleration_and_speed_limits(make_sim):
    sim = make_sim(World("empty"))
    speeds = []
    for _ in range(200):
        sim.set_cmd_vel(5.0, 0.0)
        sim.step()
        speeds.append(sim.odometry().vx)
    accel = np.diff(speeds) / sim.dt
    assert accel.max() <= MAX_ACCEL * 1.02
    assert accel.max() >= MAX_ACCEL * 0.95
    assert max(speeds) == pytest.approx(MAX_SPEED, abs=0.005)
    assert speeds[int(0.5 / sim.dt)] < 0.5 * MAX_ACCEL + 0.02


def test_saturation_keeps_the_curvature(make_sim):
    sim = make_sim(World("empty"))
    drive(sim, 2.0, 2.0, 2.0)
    odom = sim.odometry()
    assert odom.wz / odom.vx == pytest.approx(1.0, abs=0.01)
    # The outer wheel runs at the top speed.
    assert odom.vx + odom.wz * BOX.wheel_separation / 2 == pytest.approx(MAX_SPEED, abs=0.01)


def test_command_timeout_stops_the_robot(make_sim):
    sim = make_sim(World("empty"))
    sim.set_cmd_vel(0.3, 0.0)
    sim.step_until(0.5)
    assert sim.odometry().vx == pytest.approx(0.3, abs=0.003)
    sim.step_until(0.55)
    assert sim.odometry().vx < 0.3  # braking after 0.5 s of silence
    sim.step_until(0.5 + 0.3 / MAX_ACCEL + 0.05)
    assert abs(sim.odometry().vx) < 0.003
    x = sim.ground_truth().x
    sim.step_until(2.0)
    assert sim.ground_truth().x == pytest.approx(x, abs=1e-3)


def test_command_time_comes_from_the_caller(make_sim):
    sim = make_sim(World("empty"))
    sim.step_until(1.0)
    sim.set_cmd_vel(0.3, 0.0, now=0.4)  # a stale command: already timed out
    sim.step_until(1.5)
    assert abs(sim.odometry().vx) < 1e-3


@pytest.mark.parametrize("v, w", [(math.nan, 0.0), (0.2, math.inf), (-math.inf, 0.0)])
def test_non_finite_commands_are_rejected_and_the_last_one_stays(make_sim, v, w):
    sim = make_sim(World("empty"))
    sim.set_cmd_vel(0.2, 0.0)
    with pytest.raises(ValueError, match="cmd_vel with non-finite values ignored"):
        sim.set_cmd_vel(v, w)
    sim.step_until(0.4)
    assert sim.odometry().vx == pytest.approx(0.2, abs=0.003)


@pytest.mark.parametrize("description, front", [(BOX, 0.45), (ROUND, 0.3)], ids=["box", "round"])
def test_driving_into_a_wall_is_a_collision(make_sim, description, front):
    sim = make_sim(wall_ahead(1.0), description)
    drive(sim, 0.3, 0.0, 1.0)
    assert sim.collisions().count == 0 and not sim.collisions().in_contact
    drive(sim, 0.3, 0.0, 3.0)
    report = sim.collisions()
    assert report.count == 1
    assert report.in_contact
    assert report.last_obstacle == "walls[0]"
    assert report.last_point[0] == pytest.approx(1.0, abs=0.01)
    assert report.last_stamp == pytest.approx(sim.sim_time)
    # The chassis front stops at the wall face.
    assert sim.ground_truth().x == pytest.approx(1.0 - front, abs=0.01)
    drive(sim, -0.3, 0.0, 1.0)
    assert not sim.collisions().in_contact
    drive(sim, 0.3, 0.0, 3.0)
    assert sim.collisions().count == 2


def test_passing_close_to_an_obstacle_is_not_a_collision(make_sim):
    # Wall 0.32 m to the side of base_link: 2 cm from the chassis all along.
    world = World("lane", walls=(Wall((-1.0, 0.37), (4.0, 0.37)),))
    sim = make_sim(world)
    drive(sim, 0.5, 0.0, 5.0)
    assert sim.collisions().count == 0


def test_obstacle_names_in_the_report(make_sim):
    world = World("desk", cylinders=(Cylinder((1.0, 0.0), 0.3, name="bin"),))
    sim = make_sim(world)
    drive(sim, 0.3, 0.0, 3.0)
    assert sim.collisions().last_obstacle == "cylinders[0] (bin)"


# -- determinism, noise, instances -------------------------------------------------------------

def run(make_sim, seed, odom_noise=None):
    sim = make_sim(load_world("lab"), seed=seed, range_noise_std=0.01, odom_noise=odom_noise)
    trace = []
    for k in range(30):
        sim.set_cmd_vel(0.4, 0.6 * math.sin(k / 5))
        sim.step_until(sim.sim_time + 0.1)
        trace.append((sim.odometry(), sim.ground_truth(), [s.ranges.tobytes() for s in sim.due_scans()]))
    return trace


def test_same_seed_same_run(make_sim):
    assert run(make_sim, 7) == run(make_sim, 7)


def test_odometry_noise_drifts_and_is_seeded(make_sim):
    noise = OdomNoise(scale_std=0.02, speed_std=0.01)
    a, b, c = run(make_sim, 1, noise), run(make_sim, 1, noise), run(make_sim, 2, noise)
    assert [step[0] for step in a] == [step[0] for step in b]
    assert a[-1][0] != c[-1][0]
    odom, gt = a[-1][0], a[-1][1]
    assert math.hypot(odom.x - gt.x, odom.y - gt.y) > 1e-3
    clean = run(make_sim, 1)[-1]
    assert math.hypot(clean[0].x - clean[1].x, clean[0].y - clean[1].y) < 5e-3


def test_simulators_in_one_process_are_independent(make_sim):
    a, b = make_sim(World("empty")), make_sim(World("empty"))
    drive(a, 0.3, 0.0, 1.0)
    assert b.sim_time == 0.0 and b.ground_truth().x == pytest.approx(0.0, abs=1e-6)
    drive(b, 0.3, 0.0, 1.0)
    assert a.ground_truth() == b.ground_truth()


def test_other_physics_rates(make_sim):
    sim = make_sim(World("empty"), physics_rate=240)
    drive(sim, 0.3, 0.0, 5.0)
    assert sim.odometry().x == pytest.approx(1.5 - 0.3 ** 2 / (2 * MAX_ACCEL), abs=0.005)
    with pytest.raises(ValueError, match="physics_rate 155 Hz must be a multiple of the front_laser_link update "
                                         "rate 10.0 Hz"):
        SimplebotSim(World("empty"), BOX, physics_rate=155)


def test_joint_states_report_wheel_speeds(make_sim):
    sim = make_sim(World("empty"))
    drive(sim, 0.0, 1.0, 1.0)
    js = sim.joint_states()
    assert js.names == ("left_wheel_joint", "right_wheel_joint")
    wheel = 1.0 * BOX.wheel_separation / 2 / BOX.wheel_radius
    assert js.velocities == pytest.approx((-wheel, wheel), abs=0.05)


@pytest.mark.parametrize("kwargs, message", [
    ({"physics_rate": 0}, "physics_rate must be a positive number of Hz, got 0"),
    ({"physics_rate": math.inf}, "physics_rate must be a positive number of Hz, got inf"),
    ({"seed": 1.5}, "seed must be an int, got 1.5"),
    ({"range_noise_std": -0.01}, "lidar range noise std must be >= 0, got -0.01"),
])
def test_bad_simulator_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        SimplebotSim(World("empty"), BOX, **kwargs)



def test_a_kidnapped_robot_stands_where_it_was_put_and_its_odometry_does_not_know(make_sim):
    sim = make_sim(wall_ahead(3.0))
    drive(sim, 0.2, 0.0, 1.0)
    before = sim.odometry()
    sim.kidnap(Pose2D(1.5, 0.0, 0.0))
    sim.step_until(sim.sim_time + 0.05)
    sim.due_scans()     # what was cast before the kidnap
    sim.step_until(sim.sim_time + 0.5)
    truth, odom = sim.ground_truth(), sim.odometry()
    assert (truth.x, truth.y, truth.yaw) == pytest.approx((1.5, 0.0, 0.0), abs=0.01)
    assert (odom.x, odom.y, odom.yaw) == pytest.approx((before.x, before.y, before.yaw), abs=0.02)
    scan = {s.frame: s for s in sim.due_scans()}["front_laser_link"]
    laser_x = BOX.laser_poses["front_laser_link"][0]
    assert scan.ranges[CENTRE] == pytest.approx(1.5 - laser_x, abs=0.01)
    with pytest.raises(ValueError, match="kidnap pose"):
        sim.kidnap(Pose2D(3.05, 0.0, 0.0))
