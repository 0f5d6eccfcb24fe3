"""Hostile input on move_base's newer surfaces (issue 43), with the simulator in lockstep in the empty world: other
nodes' obstacles beyond the caps of ros/move_base/obstacle_msgs.py are refused before they are read and the robot
still drives, and bursts of 50 requests on a Nav2 action and on a move_base service are all answered."""

from __future__ import annotations

import math

import pytest
from action_msgs.srv import CancelGoal
from costmap_converter_msgs.msg import ObstacleArrayMsg
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient
from rclpy.node import Node
from std_srvs.srv import Empty

from simplebot_navigation.move_base.cycle_stats import ControlLoopStats
from simplebot_navigation.ros.move_base.move_base_stats import control_loop_status
from simplebot_navigation.ros.qos import SERVICE_QOS
from simplebot_navigation.scenarios import NavigationSession
from simplebot_navigation.sim.world import Pose2D
from simplebot_navigation.testing.hostile_obstacles import hostile_messages

pytestmark = pytest.mark.timeout(300)
WALL_GUARD_S = 60.0
OBSTACLES = "/move_base/TebLocalPlannerROS/obstacles"
BURST = 50


@pytest.fixture(scope="module")
def session():
    with NavigationSession("empty") as session:
        session.wait_ready(wall_timeout_s=WALL_GUARD_S)
        session.other = Node("hostile", context=session.context)
        session.driver.add_node(session.other)
        yield session


def ahead(session, distance: float) -> Pose2D:
    pose = session.pose()
    return Pose2D(pose.x + distance * math.cos(pose.yaw), pose.y + distance * math.sin(pose.yaw), pose.yaw, "ahead")


def answered(session, futures) -> int:
    """How many of the futures complete (a request the middleware dropped never does)."""
    try:
        session.run_until(stop=lambda: all(f.done() for f in futures), wall_timeout_s=20.0)
    except TimeoutError:
        pass
    return sum(f.done() for f in futures)


def test_obstacle_messages_beyond_the_caps_are_refused_and_the_robot_still_drives(session, monkeypatch):
    external = session.move_base.external_obstacles
    warned = []
    original = external._warn
    monkeypatch.setattr(external, "_warn", lambda key, text: (warned.append(text), original(key, text)))
    publisher = session.other.create_publisher(ObstacleArrayMsg, OBSTACLES, 10)
    session.run_until(stop=lambda: publisher.get_subscription_count() > 0, wall_timeout_s=WALL_GUARD_S)
    messages = hostile_messages("odom", 1.0, 0.0)        # 1 m ahead of the robot, which stands at odom's origin
    for what, raw in messages:
        publisher.publish(raw)
        session.run_for(0.1, wall_timeout_s=WALL_GUARD_S)
        assert len(external.moving_obstacles(session.move_base.controller._now())) == 0, what
    said = "\n".join(warned)
    for field, value, bound in (("obstacles", "100000 obstacles", "at most 100"),
                                ("polygon.points", "has 10000 points", "at most 100"),
                                ("radius", "radius 1e+06 m", "[0, 5] m"), ("radius", "1e+308", "[0, 5] m"),
                                ("polygon.points", "not all finite", "10000 m"), ("velocities", "1e+308", "10 m/s")):
        assert any(field in line and value in line and bound in line for line in warned), (field, value, said)
    # a goal through the place of the huge obstacle, while it is published again every 0.2 s
    before, cycles_before = session.time, session.move_base.cycle_stats.snapshot()
    run, sent = session.send_goal(ahead(session, 2.0)), [-math.inf]

    def publish_and_check() -> bool:
        if session.time - sent[0] >= 0.2:
            publisher.publish(messages[4][1])
            sent[0] = session.time
        return run.done

    session.run_until(session.time + 40.0, publish_and_check, wall_timeout_s=240.0)
    assert run.status == "SUCCEEDED", run.reason
    window = session.move_base.cycle_stats.snapshot().since(cycles_before)
    expected = (run.finished_at - before) * session.move_base.cfg.controller_frequency
    assert window.cycles >= 0.8 * expected
    # Refusing the message every 0.2 s costs the loop nothing: a message that froze it would make every fourth
    # cycle late and the median slow. One late cycle is the loaded machine's (a CI run saw 1 of 114, 0.107 s).
    assert window.missed <= 0.05 * window.cycles, window
    assert window.percentile_s(50) < 1.0 / session.move_base.cfg.controller_frequency, window


def test_fifty_cancels_at_once_on_navigate_to_pose_are_all_answered(session):
    client = ActionClient(session.other, NavigateToPose, "/navigate_to_pose", goal_service_qos_profile=SERVICE_QOS,
                          result_service_qos_profile=SERVICE_QOS, cancel_service_qos_profile=SERVICE_QOS)
    session.run_until(stop=client.server_is_ready, wall_timeout_s=WALL_GUARD_S)
    goal = NavigateToPose.Goal(pose=PoseStamped())
    goal.pose.header.frame_id = "odom"
    goal.pose.pose.position.x, goal.pose.pose.orientation.w = 1.0, 1.0
    sent = client.send_goal_async(goal)
    session.run_until(stop=sent.done, wall_timeout_s=WALL_GUARD_S)
    handle = sent.result()
    assert handle.accepted
    cancels = [handle.cancel_goal_async() for _ in range(BURST)]
    assert answered(session, cancels) == BURST
    assert cancels[0].result().return_code == CancelGoal.Response.ERROR_NONE
    client.destroy()


def test_fifty_calls_at_once_on_a_move_base_service_are_all_answered(session):
    client = session.other.create_client(Empty, "/move_base/clear_costmaps", qos_profile=SERVICE_QOS)
    session.run_until(stop=client.service_is_ready, wall_timeout_s=WALL_GUARD_S)
    assert answered(session, [client.call_async(Empty.Request()) for _ in range(BURST)]) == BURST


def test_the_diagnostics_say_the_loop_is_starved_when_no_cycle_ran():
    stats = ControlLoopStats(period_s=0.05)
    stats.ran(10.0)
    before = stats.snapshot()
    stats.account(11.0)                      # the housekeeping, 1 s later: the control timer has not run since
    status = control_loop_status(stats.snapshot().since(before), stats.snapshot(), [], 20.0, "move_base")
    values = {kv.key: kv.value for kv in status.values}
    assert status.level == DiagnosticStatus.WARN and values["missed"] == "19" and values["cycles"] == "0"
    assert "19 periods of 50 ms without a cycle" in status.message
