"""move_base's goal arbiter (ros/move_base/goal_arbiter.py): one active goal whichever interface sent it, every end
answered, the robot stopped whenever a goal ends early. Then, in lockstep in the empty world, what a user of the
running node sees: a goal's pose is checked and transformed once, and a control cycle looks the robot's pose up once
per frame and moves the plan into the local frame at most once."""

from __future__ import annotations

import math
import sys

import pytest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.task import Future

from simplebot_navigation.move_base.events import MoveBaseEvents
from simplebot_navigation.ros.move_base.goal_arbiter import GoalArbiter
from simplebot_navigation.ros.move_base.move_base_goal import MoveBaseGoal
from simplebot_navigation.ros.qos import SERVICE_QOS
from simplebot_navigation.scenarios import NavigationSession

WALL_GUARD_S = 60.0


class FakeCore:
    def __init__(self):
        self.events = MoveBaseEvents()
        self.goal = None

    def set_goal(self, goal, now):
        self.goal = goal

    def reset(self):
        self.goal = None


class Log:
    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(("info", text))

    def error(self, text):
        self.lines.append(("error", text))


def stamped(x: float, y: float, frame: str = "map") -> PoseStamped:
    pose = PoseStamped()
    pose.header.frame_id = frame
    pose.pose.position.x, pose.pose.position.y, pose.pose.orientation.w = x, y, 1.0
    return pose


@pytest.fixture
def arbiter():
    core, stops, shown, log = FakeCore(), [], [], Log()
    arbiter = GoalArbiter(core, lambda: stops.append(True), lambda: 12.0, log, shown.append)
    arbiter.core, arbiter.stops, arbiter.shown, arbiter.log = core, stops, shown, log
    ended = []
    arbiter.listen(on_end=ended.append)
    arbiter.ended = ended
    return arbiter


def goal_with_future(x: float = 1.0) -> MoveBaseGoal:
    goal = MoveBaseGoal(stamped(x, 0.0))
    goal.done = Future()
    return goal


def test_a_new_goal_preempts_the_active_one_and_is_driven_to_its_checked_pose(arbiter):
    first, second = goal_with_future(1.0), goal_with_future(2.0)
    arbiter.submit(first, stamped(1.0, 0.0))
    arbiter.submit(second, stamped(2.0, 0.5))
    assert arbiter.active is second and arbiter.core.goal == (2.0, 0.5, 0.0)
    assert first.status == GoalStatus.PREEMPTED and first.text == "preempted by a new goal"
    assert first.done.result() == GoalStatus.PREEMPTED and not second.done.done()
    assert [p.pose.position.x for p in arbiter.shown] == [1.0, 2.0]
    assert arbiter.ended == [first] and arbiter.core.events.snapshot().goals == 2


def test_ending_the_active_goal_stops_the_robot_and_drops_it_from_the_state_machine(arbiter):
    goal = goal_with_future()
    arbiter.submit(goal, stamped(1.0, 0.0))
    stops = len(arbiter.stops)
    arbiter.finish(goal, GoalStatus.ABORTED, "no control cycle for 3 s", "")
    assert arbiter.active is None and arbiter.core.goal is None and len(arbiter.stops) == stops + 1
    assert goal.done.result() == GoalStatus.ABORTED and arbiter.finished == [goal]
    assert arbiter.core.events.snapshot().outcomes == {"aborted": 1}


def test_a_cancel_for_another_goal_leaves_the_active_one_alone(arbiter):
    goal = goal_with_future()
    arbiter.submit(goal, stamped(1.0, 0.0))
    arbiter.cancel("not-its-id")
    assert arbiter.active is goal
    arbiter.cancel(goal.id)
    assert goal.status == GoalStatus.PREEMPTED and goal.text == "canceled" and arbiter.active is None


def test_a_goal_that_failed_its_check_still_preempts_then_ends_aborted_with_the_reason(arbiter):
    running, bad = goal_with_future(), goal_with_future()
    arbiter.submit(running, stamped(1.0, 0.0))
    arbiter.reject(bad, "goal has a NaN or inf", "invalid_goal")
    assert running.status == GoalStatus.PREEMPTED and arbiter.active is None and arbiter.core.goal is None
    assert bad.status == GoalStatus.ABORTED and bad.cause == "invalid_goal" and bad.done.done()
    assert ("error", "Aborting on goal because it was sent with an invalid goal: goal has a NaN or inf") \
        in arbiter.log.lines


@pytest.fixture(scope="module")
def session():
    with NavigationSession("empty") as session:
        session.wait_ready(wall_timeout_s=WALL_GUARD_S)
        session.other = Node("goal_sender", context=session.context)
        session.driver.add_node(session.other)
        yield session


def in_control_cycle() -> bool:
    frame = sys._getframe(2)
    while frame is not None:
        if frame.f_code.co_name == "_control_cycle":
            return True
        frame = frame.f_back
    return False


def counting(monkeypatch, owner, name, calls, when=lambda *args: True):
    original = getattr(owner, name)

    def counted(*args, **kwargs):
        if when(*args):
            calls.append(args)
        return original(*args, **kwargs)
    monkeypatch.setattr(owner, name, counted)


def test_a_goal_in_the_robot_frame_is_transformed_once_and_each_cycle_reads_the_pose_once(session, monkeypatch):
    move_base = session.move_base
    transforms, reads, plan_moves = [], [], []
    counting(monkeypatch, move_base.tf, "transform_pose", transforms)
    for costmap in (move_base.global_costmap, move_base.local_costmap):
        counting(monkeypatch, costmap, "get_robot_pose", reads, when=lambda *a: in_control_cycle())
    counting(monkeypatch, move_base.controller, "_in_local_frame", plan_moves)
    cycles_before = move_base.cycle_stats.snapshot()
    goal = stamped(1.0, 0.0, "base_link")
    publisher = session.other.create_publisher(PoseStamped, "/move_base_simple/goal", 1)
    session.run_until(stop=lambda: publisher.get_subscription_count() > 0, wall_timeout_s=WALL_GUARD_S)
    start = session.pose()
    publisher.publish(goal)
    session.run_until(session.time + 20.0, lambda: move_base.goal is None and move_base.events.goals > 0,
                      wall_timeout_s=120.0)
    assert move_base.arbiter.finished[-1].status == GoalStatus.SUCCEEDED, move_base.arbiter.finished[-1].text
    assert math.hypot(session.pose().x - start.x - math.cos(start.yaw), session.pose().y - start.y
                      - math.sin(start.yaw)) < 0.3
    assert len(transforms) == 1, transforms
    cycles = move_base.cycle_stats.snapshot().since(cycles_before).cycles
    shared = move_base.poses._shared()
    assert 0 < len(reads) <= cycles * (1 if shared else 2), (len(reads), cycles)
    assert len(plan_moves) <= cycles + move_base.events.replans


def test_a_nav2_goal_is_checked_once(session, monkeypatch):
    move_base = session.move_base
    checks = []
    counting(monkeypatch, move_base.tf, "transform_pose", checks)
    client = ActionClient(session.other, NavigateToPose, "/navigate_to_pose", goal_service_qos_profile=SERVICE_QOS,
                          result_service_qos_profile=SERVICE_QOS, cancel_service_qos_profile=SERVICE_QOS)
    session.run_until(stop=client.server_is_ready, wall_timeout_s=WALL_GUARD_S)
    sent = client.send_goal_async(NavigateToPose.Goal(pose=stamped(0.5, 0.0, "base_link")))
    session.run_until(stop=sent.done, wall_timeout_s=WALL_GUARD_S)
    result = sent.result().get_result_async()
    session.run_until(session.time + 20.0, result.done, wall_timeout_s=120.0)
    assert result.result().result.error_code == 0 and len(checks) == 1, (result.result(), checks)
    client.destroy()
