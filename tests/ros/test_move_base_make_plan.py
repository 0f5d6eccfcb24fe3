"""move_base's make_plan service (docs/reference.md §1.4) with the simulator in lockstep in the empty world: a
request is read by the rule of the global planner's own service (ros/move_base/move_base_goal.py plan_request), and
move_base refuses it while a goal is active."""

from __future__ import annotations

import math

import numpy as np
import pytest
from nav_msgs.srv import GetPlan
from rclpy.node import Node

from simplebot_navigation.ros.conversions import path_to_array
from simplebot_navigation.scenarios import NavigationSession
from simplebot_navigation.sim.world import Pose2D
from tests.ros.test_global_planner_ros import plan_request

pytestmark = pytest.mark.timeout(180)
WALL_GUARD_S = 60.0
GLOBAL_FRAME = "odom"


@pytest.fixture(scope="module")
def session():
    with NavigationSession("empty") as session:
        session.wait_ready(wall_timeout_s=WALL_GUARD_S)
        client = Node("make_plan_client", context=session.context)
        session.make_plan = client.create_client(GetPlan, "/move_base/make_plan")
        session.driver.add_node(client)
        session.run_until(stop=session.make_plan.service_is_ready, wall_timeout_s=WALL_GUARD_S)
        yield session


def call(session, goal, goal_frame=GLOBAL_FRAME, start=None, tolerance=0.0):
    future = session.make_plan.call_async(plan_request(goal, start, tolerance, goal_frame, GLOBAL_FRAME))
    session.run_until(stop=future.done, wall_timeout_s=WALL_GUARD_S)
    return future.result().plan


def test_a_plan_from_the_robot_or_the_given_start_in_the_global_frame(session):
    plan = call(session, (2.0, 0.0, 0.0))
    poses = path_to_array(plan)
    assert plan.header.frame_id == GLOBAL_FRAME
    assert math.dist(poses[0, :2], (session.pose().x, session.pose().y)) < 0.1
    np.testing.assert_allclose(poses[-1, :2], (2.0, 0.0), atol=1e-9)
    poses = path_to_array(call(session, (2.0, 0.0, 0.0), start=(0.0, 1.0, 0.0)))
    assert math.dist(poses[0, :2], (0.0, 1.0)) < 0.1


def test_a_goal_in_another_frame_is_moved_into_the_global_frame(session):
    robot = session.pose()
    poses = path_to_array(call(session, (2.0, 0.0, 0.0), goal_frame="base_link"))
    ahead = (robot.x + 2.0 * math.cos(robot.yaw), robot.y + 2.0 * math.sin(robot.yaw))
    assert math.dist(poses[-1, :2], ahead) < 0.05


@pytest.mark.parametrize("goal, frame, tolerance", [
    ((2.0, 0.0, 0.0), "mars", 0.0),                   # no transform
    ((math.nan, 0.0, 0.0), GLOBAL_FRAME, 0.0),        # not finite
    ((2.0, 0.0, 0.0), GLOBAL_FRAME, math.nan),        # tolerance not finite
    ((2.0, 0.0, 0.0), GLOBAL_FRAME, -1.0),            # tolerance negative
])
def test_a_request_that_cannot_be_planned_gets_an_empty_plan(session, goal, frame, tolerance):
    plan = call(session, goal, goal_frame=frame, tolerance=tolerance)
    assert len(plan.poses) == 0 and plan.header.frame_id == GLOBAL_FRAME


def test_refused_while_a_goal_is_active(session):
    run = session.send_goal(Pose2D(3.0, 0.0, 0.0, "3 m ahead"))
    session.run_for(0.5, wall_timeout_s=WALL_GUARD_S)
    assert len(call(session, (2.0, 0.0, 0.0)).poses) == 0
    session.cancel(run)
    session.run_for(2.0, lambda: run.done, wall_timeout_s=WALL_GUARD_S)
    assert len(call(session, (2.0, 0.0, 0.0)).poses) > 0
