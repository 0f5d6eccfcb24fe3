"""The kinematic crowd run (testing/crowd_drive.py): whose collision a contact is, the push, the true future, and
MPPI closed loop through one world of each crowd level at both speed settings.

The closed-loop worlds are ones the planner crosses whatever its sampling seed (four seeds each here), so a run does
not hang on the last bits of one machine's floats: a change to the planner that loses one of them has lost a world
it crossed robustly.
"""

from dataclasses import dataclass

import numpy as np
import pytest

from simplebot_navigation.perception.prediction import MotionPrediction
from simplebot_navigation.sim import MovingTracks, load_world, world_from_dict
from simplebot_navigation.testing.crowd_drive import GOAL_SENT_S, PlannerSetup, TrueFuture, drive, mppi_setup

pytestmark = pytest.mark.timeout(600)

FAR_WALL = {"from": [-5.0, -6.0], "to": [30.0, -6.0], "thickness": 0.2}


@dataclass
class Result:
    ok: bool = True
    v: float = 0.0
    omega: float = 0.0
    kind: str = "scripted"


class Scripted:
    """A planner that drives a fixed command from ``start`` s after the goal, and stands before it."""

    def __init__(self, v: float, start: float = 0.0):
        self.v, self.start, self.cycles = v, start, 0

    def set_plan(self, plan):
        self.plan = plan

    def set_dynamic_obstacles(self, rows, covariance=None):
        self.rows = rows

    def compute_velocity_commands(self, pose, velocity, costmap):
        self.cycles += 1
        return Result(v=self.v if self.cycles * 0.05 > self.start else 0.0)


def lane(walker_keyframes, goal_x=10.0):
    return world_from_dict({"walls": [FAR_WALL], "start": {"x": 0.0, "y": 0.0, "yaw": 0.0},
                            "goals": [{"x": goal_x, "y": 0.0, "yaw": 0.0}], "time_budget": 8.0,
                            "moving": [{"shape": "cylinder", "radius": 0.3, "keyframes": walker_keyframes}]})


def test_a_walker_that_runs_into_the_standing_robot_strikes_it_and_pushes_it_aside():
    # from 3 m ahead straight at the robot's centre line, slightly off it, at 1 m/s from the goal's sending on
    world = lane([[GOAL_SENT_S, 3.0, 0.1], [GOAL_SENT_S + 6.0, -3.0, 0.1]])
    result = drive(world, PlannerSetup(Scripted(0.0), 20.0, 5.0), 1.0, stop_at_collision=False)
    assert [(c.kind, c.what) for c in result.contacts] == [("standing", "walker 0")]
    assert result.contacts[0].t == pytest.approx(2.45, abs=0.05)      # 3 m less both radii at 1 m/s
    assert result.end_pose[1] == pytest.approx(0.1 - 0.55, abs=0.01)   # pushed aside until it just touches
    assert not result.success and result.moving_collisions == 0


def test_driving_into_a_walker_is_the_robots_collision_and_ends_the_run():
    world = lane([[0.0, 2.0, 0.0], [100.0, 2.0, 0.01]])                # standing in the robot's way
    result = drive(world, PlannerSetup(Scripted(0.5), 20.0, 5.0), 1.0)
    assert [(c.kind, c.what) for c in result.contacts] == [("moving", "walker 0")]
    assert result.contacts[0].speed == pytest.approx(0.5, abs=0.01)
    assert result.contacts[0].pose[0] == pytest.approx(1.45, abs=0.03)
    assert not result.success


@pytest.mark.parametrize("walker_x, kind", [(2.65, "moving"), (3.0, "standing")])
def test_a_robot_that_stopped_less_than_half_a_second_before_it_is_struck_was_still_driving(walker_x, kind):
    # the robot drives 0.5 m/s for a second and brakes, standing from about 1.3 s at x = 0.5; a walker at 1 m/s
    # from walker_x reaches it 0.3 s (2.65) or 0.65 s (3.0) after that
    world = lane([[GOAL_SENT_S, walker_x, 0.0], [GOAL_SENT_S + 10.0, walker_x - 10.0, 0.0]])
    script = Scripted(0.0)
    script.compute_velocity_commands = lambda pose, velocity, costmap, s=script: (
        setattr(s, "cycles", s.cycles + 1) or Result(v=0.5 if s.cycles <= 20 else 0.0))
    result = drive(world, PlannerSetup(script, 20.0, 5.0), 1.0, stop_at_collision=False)
    assert result.contacts[0].kind == kind


def test_the_goal_is_reached_at_the_success_radius():
    world = lane([[0.0, 5.0, 5.0], [1.0, 5.0, 5.01]], goal_x=3.0)
    result = drive(world, PlannerSetup(Scripted(1.0), 20.0, 5.0), 1.0)
    assert result.success and result.contacts == []
    assert result.end_distance <= 1.0 and result.arrived_s == pytest.approx(2.0 + 1.0 / (2 * 1.75), abs=0.06)   # the ramp to 1 m/s at 1.75 m/s^2


def test_the_true_future_is_where_the_obstacles_will_be():
    world = load_world("crowd:5")
    tracks, now = MovingTracks(world.moving), 7.3
    states = tracks.states(now)
    rows = np.column_stack([states, tracks.reach])
    lost = np.array([[50.0, 50.0, 1.0, 0.0, 0.5]])                       # no obstacle's: constant velocity
    prediction = TrueFuture(MotionPrediction(radius_growth=0.2), tracks, now)
    times = np.array([0.0, 0.5, 2.0, 4.0])
    centres = prediction.centres(np.vstack([rows[::-1], lost]), times)
    for j, t in enumerate(times):
        np.testing.assert_allclose(centres[:-1, j], tracks.states(now + t)[::-1, :2], atol=1e-12)
    np.testing.assert_allclose(centres[-1], [[50.0 + t, 50.0] for t in times])
    np.testing.assert_allclose(prediction.radii(rows, times)[0], rows[0, 4] + 0.2 * times)
    assert np.abs(centres[:-1, -1] - (rows[::-1, :2] + 4.0 * rows[::-1, 2:4])).max() > 1.0   # the walkers turn


# one world per level that MPPI crosses with every sampling seed tried, at each speed setting
CLOSED_LOOP = [(1.0, "crowd:0"), (1.0, "crowd:1"), (1.0, "crowd:8"), (1.0, "people:3"),
               (2.0, "crowd:3"), (2.0, "crowd:4"), (2.0, "crowd:11"), (2.0, "people:6")]


@pytest.mark.parametrize("speed, world", CLOSED_LOOP, ids=[f"{w}@{s:g}" for s, w in CLOSED_LOOP])
def test_mppi_crosses_a_crowd_without_a_collision_while_moving(speed, world):
    level = load_world(world)
    result = drive(level, mppi_setup(speed, seed=1), speed)
    assert result.success, (f"{world} at {speed} m/s: contacts {result.contacts}, {result.end_distance:.2f} m from "
                            f"the goal, decisions {result.kinds}")
    straight = np.hypot(level.goals[0].x - level.start.x, level.goals[0].y - level.start.y)
    assert result.arrived_s < 3.0 * straight / speed
