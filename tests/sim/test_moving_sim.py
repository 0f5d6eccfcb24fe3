"""Moving obstacles in SimplebotSim: the lidars see them, contacts are split into the robot's own
collisions and strikes on a standing robot, ground truth, and runs stay deterministic."""

import math

import numpy as np
import pytest

from simplebot_description import robot_description
from simplebot_navigation.sim import MovingObstacle, MovingObstacleState, Pose2D, SimplebotSim, World

BOX = robot_description("box")
CENTRE = 341  # beam at angle 0 of 683 over [-2.0944, 2.0944]
LASER_X = BOX.laser_poses["front_laser_link"][0]


def crossing(*keyframes, radius=0.2, **kwargs) -> MovingObstacle:
    return MovingObstacle("cylinder", tuple(keyframes), radius=radius, **kwargs)


@pytest.fixture
def make_sim():
    sims = []

    def make(world, **kwargs):
        sims.append(SimplebotSim(world, BOX, **kwargs))
        return sims[-1]

    yield make
    for sim in sims:
        sim.close()


def drive(sim, v, seconds):
    end = sim.sim_time + seconds
    while sim.sim_time < end - 1e-9:
        sim.set_cmd_vel(v, 0.0)
        sim.step_until(min(end, sim.sim_time + 0.1))


def front_range_at(sim, t):
    sim.step_until(t)
    return [s for s in sim.due_scans() if s.frame == "front_laser_link"][-1].ranges[CENTRE]


def test_the_front_lidar_sees_a_cylinder_walk_away(make_sim):
    # Straight ahead, from 2 m to 4 m over 2 s (1 m/s); the beam meets its near side.
    sim = make_sim(World("walk", moving=(crossing((0.0, 2.0, 0.0), (2.0, 4.0, 0.0)),)))
    assert front_range_at(sim, 0.5) == pytest.approx(2.5 - 0.2 - LASER_X, abs=0.01)
    assert front_range_at(sim, 1.5) == pytest.approx(3.5 - 0.2 - LASER_X, abs=0.01)
    assert front_range_at(sim, 3.0) == pytest.approx(4.0 - 0.2 - LASER_X, abs=0.01)   # resting at the end


def test_the_lidars_see_boxes_but_not_over_low_obstacles(make_sim):
    lidar_z = BOX.laser_poses["front_laser_link"][2]
    cart = MovingObstacle("box", ((0.0, 3.0, 0.0), (1.0, 3.0, 1.0)), size=(0.4, 1.0))
    low = crossing((0.0, 1.0, 0.0), (1.0, 1.0, 0.5), height=lidar_z / 2)
    sim = make_sim(World("cart", moving=(cart, low)))
    # The beam passes over the low cylinder 1 m ahead and meets the cart's near face.
    assert front_range_at(sim, 0.5) == pytest.approx(3.0 - 0.2 - LASER_X, abs=0.01)


def test_ground_truth_of_the_moving_obstacles(make_sim):
    cart = MovingObstacle("box", ((0.0, 3.0, 3.0), (1.0, 4.0, 3.0)), size=(0.5, 0.4), name="cart")
    sim = make_sim(World("two", moving=(crossing((0.0, -3.0, 0.0), (2.0, -3.0, 2.0)), cart)))
    sim.step_until(0.5)
    assert sim.moving_obstacle_states() == [
        MovingObstacleState("moving[0]", "cylinder", -3.0, 0.5, 0.0, 1.0, 0.2),
        MovingObstacleState("moving[1] (cart)", "box", 3.5, 3.0, 1.0, 0.0, (0.5, 0.4))]


def test_an_obstacle_given_new_keyframes_while_running_appears_at_the_next_step(make_sim):
    # Parked 20 m aside until a moment chosen at run time, then 2 m ahead: seen and touched there.
    sim = make_sim(World("appear", moving=(crossing((0.0, 0.0, 20.0), (1.0, 0.0, 20.0), name="post"),)))
    assert np.isinf(front_range_at(sim, 0.5))
    sim.set_moving_keyframes(0, [(0.0, 0.0, 20.0), (0.6, 0.0, 20.0), (0.61, 2.0, 0.0)])
    assert front_range_at(sim, 0.7) == pytest.approx(2.0 - 0.2 - LASER_X, abs=0.01)
    assert sim.moving_obstacle_states()[0][:4] == ("moving[0] (post)", "cylinder", 2.0, 0.0)
    sim.set_moving_keyframes(0, [(0.0, 0.6, 0.0), (1.0, 0.6, 0.0)])           # onto the robot (front at 0.45)
    sim.step_until(0.8)
    assert sim.collisions().count_standing == 1 and sim.collisions().last_obstacle == "moving[0] (post)"


@pytest.mark.parametrize("index, keyframes, error", [
    (1, [(0.0, 1.0, 1.0), (1.0, 1.0, 1.0)], IndexError),
    (0, [(0.0, 1.0, 1.0)], ValueError),                            # fewer than two
    (0, [(1.0, 1.0, 1.0), (0.5, 1.0, 1.0)], ValueError),           # time going back
])
def test_bad_new_keyframes_are_refused_and_the_old_track_stays(make_sim, index, keyframes, error):
    sim = make_sim(World("keep", moving=(crossing((0.0, 3.0, 0.0), (1.0, 3.0, 0.0)),)))
    with pytest.raises(error):
        sim.set_moving_keyframes(index, keyframes)
    sim.step_until(0.5)
    assert sim.moving_obstacle_states()[0].x == 3.0


def test_an_obstacle_running_into_a_standing_robot_is_a_strike(make_sim):
    # It comes from behind at 0.5 m/s and runs on through the robot's place.
    sim = make_sim(World("struck", moving=(crossing((0.0, -2.0, 0.0), (8.0, 2.0, 0.0), name="walker"),)))
    sim.step_until(4.0)
    report = sim.collisions()
    assert (report.count, report.count_moving, report.count_standing) == (1, 0, 1)
    assert (report.last_kind, report.last_obstacle) == ("standing", "moving[0] (walker)")


def test_a_robot_driving_into_a_moving_obstacle_collides_itself(make_sim):
    # A slow cylinder crossing the robot's lane; the robot drives into its side.
    sim = make_sim(World("lane", moving=(crossing((0.0, 1.2, -0.5), (40.0, 1.2, 0.5), radius=0.3),)))
    drive(sim, 0.4, 4.0)
    report = sim.collisions()
    assert (report.count_moving, report.count_standing, report.last_kind) == (1, 0, "moving")
    assert report.count == 1 and report.last_obstacle == "moving[0]"


def test_a_robot_that_just_stopped_still_counts_as_moving(make_sim):
    # The robot stops at t = 2 s; the obstacle arrives 0.3 s later, within the half second.
    sim = make_sim(World("late", moving=(crossing((2.0, 2.0, 0.0), (2.3, 0.8 + 0.2, 0.0)),)))
    drive(sim, 0.2, 2.0)
    sim.set_cmd_vel(0.0, 0.0)
    sim.step_until(2.6)
    report = sim.collisions()
    assert (report.count_moving, report.count_standing) == (1, 0)


def test_static_obstacles_only_do_not_change_the_counts(make_sim):
    sim = make_sim(World("empty", start=Pose2D(0.0, 0.0, 0.0)))
    drive(sim, 0.3, 1.0)
    report = sim.collisions()
    assert (report.count, report.count_moving, report.count_standing, report.last_kind) == (0, 0, 0, None)
    assert sim.moving_obstacle_states() == []


def run(make_sim):
    world = World("crowd", moving=tuple(
        crossing((0.0, 3.0, -2.0 + k), (3.0, -1.0, -2.0 + k), (6.0, 3.0, -1.5 + k), loop=True,
                 interpolation="spline", phase=0.3 * k) for k in range(4)))
    sim = make_sim(world, seed=3, range_noise_std=0.01)
    trace = []
    for k in range(40):
        sim.set_cmd_vel(0.3, 0.4 * math.sin(k / 4))
        sim.step_until(sim.sim_time + 0.1)
        trace.append((sim.ground_truth(), sim.collisions(), sim.moving_obstacle_states(),
                      [s.ranges.tobytes() for s in sim.due_scans()]))
    return trace


def test_same_world_commands_and_seed_same_run(make_sim):
    a, b = run(make_sim), run(make_sim)
    assert a == b
    assert any(np.isfinite(np.frombuffer(scan, np.float32)).any() for step in a for scan in step[3])
