"""The BARN challenge's score (2024 on) as the campaign and scenario reports give it, and its reference path."""

import math

import pytest

from simplebot_navigation.scenarios.runner import CHALLENGE_SPEED, challenge_score, reference_length
from simplebot_navigation.sim.world import Pose2D
from simplebot_navigation.sim.world_loader import load_world


@pytest.mark.parametrize("time_s, score", [(5.0, 0.5), (10.0, 0.5), (20.0, 0.25), (40.0, 0.125), (400.0, 0.125)])
def test_the_score_is_optimal_time_over_the_clipped_actual_time(time_s, score):
    reference = 10.0          # OT = 5 s at 2 m/s: the score saturates at 0.5 from an average 1 m/s
    assert challenge_score(True, time_s, reference) == pytest.approx(score)


def test_a_failed_run_or_a_missing_reference_scores_nothing():
    assert challenge_score(False, 10.0, 10.0) == 0.0
    assert challenge_score(True, 10.0, math.nan) == 0.0 and challenge_score(True, math.inf, 10.0) == 0.0


def test_a_forest_uses_the_c_space_path_its_generator_measured():
    world = load_world("forest:3", robot_radius=0.25)
    goal = world.goals[0]
    assert reference_length(world, world.start, goal) == world.extra["cspace"]["path_length"]
    assert world.extra["cspace"]["path_length"] >= math.hypot(goal.x - world.start.x, goal.y - world.start.y)
    elsewhere = Pose2D(world.start.x + 1.0, world.start.y, 0.0)
    assert reference_length(world, elsewhere, goal) < world.extra["cspace"]["path_length"]
    assert CHALLENGE_SPEED == 2.0
