"""Perception's limit: the simulator's moving obstacles handed to move_base as its tracker's would be."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from simplebot_navigation.scenarios.campaign.spec import SpecError, plan, spec_from_dict
from simplebot_navigation.scenarios.true_obstacles import CLEARING_MARGIN_M, SENSOR_RANGE_M, TrueObstacles
from simplebot_navigation.sim.moving import MovingObstacleState


class FakeSim:
    """The simulator's ground truth, as TrueObstacles reads it: the robot's true pose and its odometry."""

    def __init__(self):
        self.truth = SimpleNamespace(x=10.0, y=0.0, yaw=0.0)
        self.odom = SimpleNamespace(x=0.0, y=0.0, yaw=math.pi / 2)   # odometry turned a quarter (pushed, say)
        self.states = [MovingObstacleState("walker 0", "cylinder", 12.0, 0.0, 1.0, 0.0, 0.25),
                       MovingObstacleState("cart 1", "box", 10.0, -1.0, 0.0, 0.5, (0.6, 0.8)),
                       MovingObstacleState("walker 2", "cylinder", 10.0 + SENSOR_RANGE_M + 0.3, 0.0, 0.0, 0.0, 0.25)]

    def ground_truth(self, robot=0):
        return self.truth

    def odometry(self, robot=0):
        return self.odom

    def moving_obstacle_states(self):
        return self.states


def test_obstacles_in_range_are_where_they_truly_are_relative_to_the_robot_in_odometry():
    truth = TrueObstacles(FakeSim(), "odom")
    obstacles = truth.moving_obstacles(3.0)
    assert obstacles.frame == "odom" and obstacles.stamp == 3.0
    # 2 m ahead of the robot, walking on: ahead is +y in this odometry; the box is 1 m to the right, its radius
    # the circle around it; the walker 5.9 m off (5.65 m from its edge) is beyond the lidars
    assert obstacles.rows == pytest.approx(np.array([[0.0, 2.0, 0.0, 1.0, 0.25], [1.0, 0.0, -0.5, 0.0, 0.5]]))
    assert not obstacles.covariance.any()


def test_the_costmaps_clear_where_obstacles_are_and_were_within_the_clearing_time():
    sim = FakeSim()
    truth = TrueObstacles(sim, "odom")
    truth.clearing_circles(1.0)
    sim.states = sim.states[:1]
    sim.states[0] = sim.states[0]._replace(x=12.5)
    circles = truth.clearing_circles(1.3)
    assert circles[:, :2] == pytest.approx(np.array([[0.0, 2.0], [1.0, 0.0], [0.0, 2.5]]))
    assert circles[:, 2] == pytest.approx(np.array([0.25, 0.5, 0.25]) + CLEARING_MARGIN_M)
    assert len(truth.clearing_circles(1.9)) == 1          # what was there at 1.0 and 1.3 s is no longer cleared


def test_a_campaign_cannot_replace_a_tracker_it_turned_off():
    with pytest.raises(SpecError, match="true_obstacles replaces the tracker"):
        plan(spec_from_dict({"worlds": "crowd:0", "robots": ["round:0.25"],
                             "params": ["true_obstacles no_moving_obstacles"]}))
