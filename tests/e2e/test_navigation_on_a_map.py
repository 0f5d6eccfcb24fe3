"""Navigation on a map, end to end in lockstep: map_server and amcl on the lab's exported map, encoders drifting.
A goal given in map lands where the map says although the odometry drifted, Nav2's NavigateToPose works in map with
amcl, and a kidnapped robot finds itself again after global_localization."""

import math

import pytest
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.srv import GetState
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient

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


def test_nav2s_navigate_to_pose_in_map_with_amcl(on_map):
    client = on_map.client
    states = {}
    for name in ("amcl", "bt_navigator"):
        future = client.create_client(GetState, f"{name}/get_state").call_async(GetState.Request())
        on_map.run_until(None, future.done, wall_timeout_s=30)
        states[name] = future.result().current_state.label
    assert states == {"amcl": "active", "bt_navigator": "active"}
    goal = Pose2D(-6.5, 3.5, 0.0)     # 1.8 m on from nw_office, where the test before left the robot: 2.2 m clear
    request = NavigateToPose.Goal(pose=PoseStamped())
    request.pose.header.frame_id = "map"
    request.pose.pose.position.x, request.pose.pose.position.y = goal.x, goal.y
    request.pose.pose.orientation.z, request.pose.pose.orientation.w = math.sin(goal.yaw / 2), math.cos(goal.yaw / 2)
    action = ActionClient(client, NavigateToPose, "navigate_to_pose")
    on_map.run_until(None, action.server_is_ready, wall_timeout_s=30)
    frames = []
    sent = action.send_goal_async(request, feedback_callback=lambda m: frames.append(
        m.feedback.current_pose.header.frame_id))
    on_map.run_until(None, sent.done, wall_timeout_s=30)
    result = sent.result().get_result_async()
    on_map.run_until(on_map.time + 90.0, result.done, wall_timeout_s=300)
    assert result.done() and result.result().status == 4, result.result().result.error_msg if result.done() else ""
    truth = on_map.pose()
    assert math.hypot(truth.x - goal.x, truth.y - goal.y) < 0.3
    assert frames and set(frames) == {"map"}


def test_a_kidnapped_robot_is_found_again_after_global_localization(on_map):
    seconds = relocalization_time(on_map, Pose2D(-6.0, 5.0, -1.2), limit_s=30.0)
    assert seconds is not None and seconds <= 15.0
