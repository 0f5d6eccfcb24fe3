"""Navigation on a map, end to end in lockstep: map_server and amcl on the lab's exported map, encoders drifting.
A goal given in map lands where the map says although the odometry drifted, and a kidnapped robot finds itself
again after global_localization."""

import math

import pytest

from simplebot_navigation.scenarios.localization import relocalization_time
from simplebot_navigation.scenarios.runner import run_goal, time_budget
from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D

pytestmark = [pytest.mark.e2e, pytest.mark.timeout(600)]


@pytest.fixture(scope="module")
def on_map():
    with NavigationSession("lab", seed=1, map_name="lab") as session:
        session.wait_ready(wall_timeout_s=120.0)
        yield session


def test_a_goal_in_map_lands_on_the_truth_while_odometry_drifts(on_map):
    goal = on_map.world.goal("nw_office")
    result = run_goal(on_map, goal, time_budget(on_map.world, on_map.pose(), goal, 0.4))
    assert result.success, result.failures
    assert result.position_error < 0.2 and result.collisions == 0
    assert result.localization.position_rms < 0.08 and result.localization.position_p95 < 0.15
    assert math.degrees(result.localization.yaw_rms) < 2.0
    odom, truth = on_map.sim.sim.odometry(), on_map.pose()
    start = on_map.world.start
    odom_world = (start.x + odom.x, start.y + odom.y)          # the lab's start is at the origin, yaw 0
    assert math.hypot(odom_world[0] - truth.x, odom_world[1] - truth.y) > 2 * result.localization.position_rms


def test_a_kidnapped_robot_is_found_again_after_global_localization(on_map):
    seconds = relocalization_time(on_map, Pose2D(-6.0, 5.0, -1.2), limit_s=30.0)
    assert seconds is not None and seconds <= 15.0
