"""Several robots in one SimplebotSim: they see each other, never themselves, bump into each other,
and start where the world file or the starts argument puts them."""

import math

import pytest

from simplebot_description import robot_description
from simplebot_navigation.sim import Pose2D, SimplebotSim, World, load_world, world_from_dict
from simplebot_navigation.sim.starts import parse_starts, robot_starts

BOX = robot_description("box")
CENTRE = 341  # beam at angle 0
EMPTY = World("empty")


def scans(sim, robot):
    sim.step_until(sim.sim_time + 0.1)
    return {s.frame: s for s in sim.due_scans(robot)}


@pytest.fixture
def make_sim():
    sims = []

    def make(starts, world=EMPTY, description=BOX):
        sims.append(SimplebotSim(world, description, starts=starts))
        return sims[-1]

    yield make
    for sim in sims:
        sim.close()


def test_a_robot_ahead_is_seen_by_the_lidar_but_not_by_itself(make_sim):
    # robot 1 faces robot 2, whose back face is 3 m - 0.45 m ahead of robot 1's base_link.
    sim = make_sim([Pose2D(0.0, 0.0, 0.0), Pose2D(3.0, 0.0, 0.0)])
    laser_x = BOX.laser_poses["front_laser_link"][0]
    first = scans(sim, 0)["front_laser_link"]
    assert first.ranges[CENTRE] == pytest.approx(3.0 - 0.45 - laser_x, abs=0.01)
    # Robot 2's back lidar sees robot 1's front face; its front lidar sees nothing in the empty world.
    second = {s.frame: s for s in sim.due_scans(1)}
    assert second["back_laser_link"].ranges[CENTRE] == pytest.approx(3.0 - 0.45 - laser_x, abs=0.01)
    assert all(math.isinf(r) for r in second["front_laser_link"].ranges)


def test_the_other_robot_is_seen_where_it_has_moved(make_sim):
    sim = make_sim([Pose2D(0.0, 0.0, 0.0), Pose2D(3.0, 0.0, 0.0)])
    start = scans(sim, 0)["front_laser_link"].ranges[CENTRE]
    while sim.sim_time < 2.0:
        sim.set_cmd_vel(0.5, 0.0, robot=1)
        sim.step_until(sim.sim_time + 0.1)
    seen = scans(sim, 0)["front_laser_link"].ranges[CENTRE]  # taken at the end of the step, as is the truth
    moved = sim.ground_truth(1).x - 3.0
    assert moved > 0.5
    assert seen == pytest.approx(start + moved, abs=0.01)
    assert sim.ground_truth(0).x == pytest.approx(0.0, abs=1e-3)  # robot 1 had no command


def test_robots_driving_into_each_other_both_count_a_collision(make_sim):
    sim = make_sim([Pose2D(0.0, 0.0, 0.0, "robot1"), Pose2D(2.0, 0.0, math.pi, "robot2")])
    while sim.sim_time < 3.0:
        for robot in (0, 1):
            sim.set_cmd_vel(0.4, 0.0, robot=robot)
        sim.step_until(sim.sim_time + 0.1)
    first, second = sim.collisions(0), sim.collisions(1)
    assert first.count >= 1 and second.count >= 1
    assert (first.last_obstacle, second.last_obstacle) == ("robot2", "robot1")
    # They stopped where their bodies meet: 0.45 m each side of the midpoint.
    assert sim.ground_truth(1).x - sim.ground_truth(0).x == pytest.approx(0.9, abs=0.05)


def test_one_robot_keeps_the_seeded_noise_of_a_lone_simulator():
    world = load_world("lab")
    with SimplebotSim(world, BOX, range_noise_std=0.01, seed=3) as alone, \
            SimplebotSim(world, BOX, range_noise_std=0.01, seed=3, starts=[world.start]) as listed:
        assert (scans(alone, 0)["front_laser_link"].ranges == scans(listed, 0)["front_laser_link"].ranges).all()


def test_too_many_robots_are_refused():
    with pytest.raises(ValueError, match="1 to 16 robots, got 17"):
        SimplebotSim(EMPTY, BOX, starts=[Pose2D(2.0 * i, 0.0) for i in range(17)])


# -- starts --------------------------------------------------------------------------------------

def test_lab_world_has_three_starts_that_pass_the_checks():
    world = load_world("lab")
    starts = robot_starts(world, ["robot1", "robot2", "robot3"], "", BOX)
    assert [(p.x, p.y, p.name) for p in starts] == [(-5.0, -3.0, "robot1"), (2.5, 3.0, "robot2"),
                                                    (6.0, -3.5, "robot3")]


def test_starts_from_the_argument_win_over_the_world_and_one_robot_uses_the_world_start():
    world = load_world("lab")
    assert robot_starts(world, ["a", "b"], "1,0,0.5; 3,0", BOX) == (Pose2D(1.0, 0.0, 0.5, "a"),
                                                                    Pose2D(3.0, 0.0, 0.0, "b"))
    assert robot_starts(world, ["simplebot"], "", BOX) == (Pose2D(0.0, 0.0, 0.0, "simplebot"),)


@pytest.mark.parametrize("text, message", [
    ("1,2,3;4,x,0", "starts: entry 2 '4,x,0' is not x,y or x,y,yaw"),
    ("1,2,3,4", "starts: entry 1 '1,2,3,4' is not x,y or x,y,yaw"),
    ("1,nan", "entry 1 '1,nan'"),
])
def test_malformed_starts_name_the_entry(text, message):
    with pytest.raises(ValueError, match=message):
        parse_starts(text)


def test_bad_starts_are_named():
    lab = load_world("lab")
    with pytest.raises(ValueError, match=r"4 robots but 3 start\(s\) in lab.yaml's starts list"):
        robot_starts(lab, ["r1", "r2", "r3", "r4"], "", BOX)
    with pytest.raises(ValueError, match=r"2 robots but 1 start\(s\) in the starts argument"):
        robot_starts(lab, ["r1", "r2"], "0,0,0", BOX)
    with pytest.raises(ValueError, match=r"lab.yaml: start of r2 \(0.0, 1.25\) is inside walls\[5\]"):
        robot_starts(lab, ["r1", "r2"], "0,0,0;0,1.25,0", BOX)
    with pytest.raises(ValueError, match=r"starts of r1 \(0.0, 0.0\) and r2 \(0.8, 0.0\) are 0.80 m apart: "
                                         r"the robots would overlap \(they need 1.08 m\)"):
        robot_starts(lab, ["r1", "r2"], "0,0,0;0.8,0,0", BOX)


def test_world_file_starts_are_validated_and_written_back():
    world = world_from_dict({"starts": [[1, 2, 0.5], [3, 4]]}, source="w.yaml")
    assert world.starts == (Pose2D(1.0, 2.0, 0.5), Pose2D(3.0, 4.0, 0.0))
    assert world_from_dict(world.to_dict()).starts == world.starts
    with pytest.raises(ValueError, match=r"w.yaml: starts\[1\]: expected \[x, y, yaw\], got \{'x': 1\}"):
        world_from_dict({"starts": [[0, 0], {"x": 1}]}, source="w.yaml")
    with pytest.raises(ValueError, match=r"w.yaml: starts\[0\].y: expected a number, got str 'a'"):
        world_from_dict({"starts": [[0, "a"]]}, source="w.yaml")
