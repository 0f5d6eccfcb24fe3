"""Nav2's front door end to end: a client that knows only rclpy and nav2_msgs drives the lab robot.

The simulator and move_base run in lockstep in this process (one stack for the module, started by the scenario
session); the client below uses nothing of this project: ActionClient and create_client on nav2_msgs, as a Nav2
user's code would. The robot starts at the lab's origin, facing east along the 2.5 m corridor (odom is the start
pose, so odom coordinates are the world's here), and the tests take it east and back in the order they are
written: a path, a goal with its feedback, a back-up, three poses, waypoints with one outside the map, a goal
preempted through /move_base_simple/goal, bad input of every kind, and a last goal. What is served: README's
"Nav2 clients" and docs/reference.md §9.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pytest
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import State
from lifecycle_msgs.srv import GetState
from nav2_msgs.action import (BackUp, ComputePathToPose, DriveOnHeading, FollowWaypoints, NavigateThroughPoses,
                              NavigateToPose, Spin, Wait)
from nav2_msgs.srv import (ClearCostmapAroundPose, ClearCostmapAroundRobot, ClearCostmapExceptRegion,
                           ClearEntireCostmap, GetCostmap)
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.parameter import Parameter

from simplebot_navigation.scenarios import NavigationSession

pytestmark = [pytest.mark.timeout(300), pytest.mark.e2e]

WALL_GUARD_S = 120.0      # per wait: only a hang should reach it
FRAME = "odom"            # the lab's global frame without a map
LETHAL = 254              # costmap_2d's and Nav2's lethal cost

ACTIONS = {"navigate_to_pose": NavigateToPose, "navigate_through_poses": NavigateThroughPoses,
           "follow_waypoints": FollowWaypoints, "compute_path_to_pose": ComputePathToPose, "spin": Spin,
           "backup": BackUp, "drive_on_heading": DriveOnHeading, "wait": Wait}
SERVICES = {"global_costmap/clear_entirely_global_costmap": ClearEntireCostmap,
            "local_costmap/clear_entirely_local_costmap": ClearEntireCostmap,
            "global_costmap/get_costmap": GetCostmap, "local_costmap/get_costmap": GetCostmap,
            "local_costmap/clear_costmap_around_robot": ClearCostmapAroundRobot,
            "local_costmap/clear_costmap_except_region": ClearCostmapExceptRegion,
            "local_costmap/clear_costmap_around_pose": ClearCostmapAroundPose,
            "bt_navigator/get_state": GetState}


def seconds(duration: Duration) -> float:
    return duration.sec + duration.nanosec * 1e-9


def duration(s: float) -> Duration:
    return Duration(sec=int(s), nanosec=int(round((s - int(s)) * 1e9)))


@dataclass
class Goal:
    """One goal sent through an action: the goal response, the feedback as it came, and the result."""

    action: str
    feedback: list = field(default_factory=list)     # (the client's time in s, feedback message)
    handle: object = None
    result_future: object = None
    rejected: bool = False

    def on_response(self, future) -> None:
        self.handle = future.result()
        if self.handle.accepted:
            self.result_future = self.handle.get_result_async()
        else:
            self.rejected = True

    @property
    def done(self) -> bool:
        return self.rejected or (self.result_future is not None and self.result_future.done())

    @property
    def status(self) -> int:
        return self.result_future.result().status

    @property
    def result(self):
        return self.result_future.result().result


class Nav2Client(Node):
    """A Nav2 user's client for the robot in ``namespace``: actions, services and the old goal topic."""

    def __init__(self, context, namespace: str = ""):
        super().__init__("nav2_client", namespace=namespace, context=context,
                         parameter_overrides=[Parameter("use_sim_time", value=True)])
        self.action_clients = {name: ActionClient(self, kind, name) for name, kind in ACTIONS.items()}
        self.service_clients = {name: self.create_client(kind, name) for name, kind in SERVICES.items()}
        self.simple_goal = self.create_publisher(PoseStamped, "move_base_simple/goal", 1)

    def now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def missing(self) -> list[str]:
        """The actions, services and topic not (yet) served."""
        return ([name for name, a in self.action_clients.items() if not a.server_is_ready()]
                + [name for name, s in self.service_clients.items() if not s.service_is_ready()]
                + (["move_base_simple/goal"] if self.simple_goal.get_subscription_count() == 0 else []))

    def ready(self) -> bool:
        return not self.missing()

    def pose(self, x: float, y: float, yaw: float, frame: str = FRAME) -> PoseStamped:
        msg = PoseStamped()
        msg.header.frame_id = frame
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.pose.position.x, msg.pose.position.y = float(x), float(y)
        msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        return msg

    def send(self, action: str, goal) -> Goal:
        sent = Goal(action)
        future = self.action_clients[action].send_goal_async(
            goal, feedback_callback=lambda msg: sent.feedback.append((self.now(), msg.feedback)))
        future.add_done_callback(sent.on_response)
        return sent

    def call(self, service: str, request=None):
        return self.service_clients[service].call_async(SERVICES[service].Request() if request is None else request)


# -- goals ------------------------------------------------------------------------------------------------------
def navigate_to(client: Nav2Client, x: float, y: float, yaw: float, frame: str = FRAME) -> NavigateToPose.Goal:
    return NavigateToPose.Goal(pose=client.pose(x, y, yaw, frame))


def through(client: Nav2Client, poses) -> NavigateThroughPoses.Goal:
    return NavigateThroughPoses.Goal(poses=[client.pose(*p) for p in poses])


def back_up(distance: float, speed: float = 0.15, allowance: float = 10.0) -> BackUp.Goal:
    goal = BackUp.Goal(speed=speed, time_allowance=duration(allowance))
    goal.target.x = distance
    return goal


def spin(yaw: float, allowance: float = 10.0) -> Spin.Goal:
    return Spin.Goal(target_yaw=yaw, time_allowance=duration(allowance))


# -- the stack --------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def lab():
    with NavigationSession("lab") as session:
        session.wait_ready(wall_timeout_s=WALL_GUARD_S)
        session.nav2 = Nav2Client(session.context)
        session.driver.add_node(session.nav2)
        try:
            assert session.run_until(session.time + 30.0, session.nav2.ready, wall_timeout_s=WALL_GUARD_S), \
                f"not served after 30 s of simulated time: {', '.join(session.nav2.missing())}"
            yield session
        finally:
            session.driver.remove_node(session.nav2)
            session.nav2.destroy_node()


def finish(session, goal: Goal, sim_s: float) -> Goal:
    """Run until the goal has ended, at most sim_s of simulated time."""
    session.run_until(session.time + sim_s, lambda: goal.done, wall_timeout_s=WALL_GUARD_S)
    assert goal.done, f"{goal.action}: not finished after {sim_s} s of simulated time"
    return goal


def answer(session, future, sim_s: float = 5.0):
    session.run_until(session.time + sim_s, future.done, wall_timeout_s=WALL_GUARD_S)
    assert future.done(), f"no answer within {sim_s} s of simulated time"
    return future.result()


def succeeded(goal: Goal) -> None:
    assert not goal.rejected, f"{goal.action}: rejected"
    assert goal.status == GoalStatus.STATUS_SUCCEEDED, \
        f"{goal.action}: status {goal.status}, error {goal.result.error_code}: {goal.result.error_msg!r}"
    assert goal.result.error_code == 0, goal.result.error_msg


def near(session, x: float, y: float, tolerance: float) -> bool:
    pose = session.pose()
    return math.hypot(pose.x - x, pose.y - y) < tolerance


def moved(session, since) -> float:
    now = session.pose()
    return math.hypot(now.x - since.x, now.y - since.y) + abs(math.remainder(now.yaw - since.yaw, math.tau))


# -- the tests, in the order the robot goes -----------------------------------------------------------------------
def test_bt_navigator_is_active(lab):
    response = answer(lab, lab.nav2.call("bt_navigator/get_state"))
    assert response.current_state.label == "active"
    assert response.current_state.id == State.PRIMARY_STATE_ACTIVE


def test_the_costmaps_can_be_read_and_cleared(lab):
    robot = lab.pose()
    for name, metres, resolution in (("global_costmap", 30.0, 0.2), ("local_costmap", 5.0, 0.05)):
        costmap = answer(lab, lab.nav2.call(f"{name}/get_costmap")).map
        meta = costmap.metadata
        assert meta.resolution == pytest.approx(resolution), name
        assert (meta.size_x, meta.size_y) == (round(metres / resolution),) * 2, name
        assert len(costmap.data) == meta.size_x * meta.size_y, name
        assert costmap.header.frame_id == FRAME, name
        assert LETHAL in costmap.data, f"{name}: the corridor's walls are not in it"
        # the robot's own cell is free of obstacles
        col = int((robot.x - meta.origin.position.x) / meta.resolution)
        row = int((robot.y - meta.origin.position.y) / meta.resolution)
        assert costmap.data[row * meta.size_x + col] < LETHAL, name
    for service in ("global_costmap/clear_entirely_global_costmap", "local_costmap/clear_entirely_local_costmap"):
        assert isinstance(answer(lab, lab.nav2.call(service)), ClearEntireCostmap.Response), service
    around = ClearCostmapAroundPose.Request(pose=lab.nav2.pose(robot.x, robot.y, robot.yaw), reset_distance=2.0)
    for service, request in (("local_costmap/clear_costmap_around_robot", ClearCostmapAroundRobot.Request(
                                  reset_distance=2.0)),
                             ("local_costmap/clear_costmap_except_region", ClearCostmapExceptRegion.Request(
                                  reset_distance=3.0)),
                             ("local_costmap/clear_costmap_around_pose", around)):
        assert answer(lab, lab.nav2.call(service, request)) is not None, service
    lab.run_for(1.0, wall_timeout_s=WALL_GUARD_S)    # the lasers mark the walls again


def test_compute_path_to_pose_plans_without_driving(lab):
    start = lab.pose()
    goal = ComputePathToPose.Goal(goal=lab.nav2.pose(2.5, 0.0, 0.0), use_start=False)
    planned = finish(lab, lab.nav2.send("compute_path_to_pose", goal), 10.0)
    succeeded(planned)
    path = planned.result.path
    assert path.header.frame_id == FRAME
    assert len(path.poses) >= 2
    first, last = path.poses[0].pose.position, path.poses[-1].pose.position
    assert math.hypot(first.x - start.x, first.y - start.y) < 0.3, (first.x, first.y)
    assert math.hypot(last.x - 2.5, last.y) < 0.25, (last.x, last.y)
    assert seconds(planned.result.planning_time) >= 0.0
    lab.run_for(1.0, wall_timeout_s=WALL_GUARD_S)
    assert moved(lab, start) < 0.01, "computing a path drove the robot"


def test_navigate_to_pose_reaches_the_goal_with_sane_feedback(lab):
    navigating = finish(lab, lab.nav2.send("navigate_to_pose", navigate_to(lab.nav2, 2.5, 0.0, 0.0)), 40.0)
    succeeded(navigating)
    assert near(lab, 2.5, 0.0, 0.25), lab.pose()
    feedback = [f for _, f in navigating.feedback]
    assert len(feedback) >= 5, f"{len(feedback)} feedback messages"
    remaining = [f.distance_remaining for f in feedback]
    assert remaining[-1] < remaining[0] - 1.0, remaining
    assert all(math.isfinite(r) and r >= 0.0 for r in remaining), remaining
    # along the plan: never shorter than the straight line, and in the straight corridor not much longer
    straight = [math.hypot(f.current_pose.pose.position.x - 2.5, f.current_pose.pose.position.y) for f in feedback]
    assert all(s - 0.1 <= r <= s + 0.3 for r, s in zip(remaining, straight)), list(zip(remaining, straight))
    eta = [seconds(f.estimated_time_remaining) for f in feedback]
    assert all(math.isfinite(t) and 0.0 <= t < 3600.0 for t in eta), eta
    elapsed = [seconds(f.navigation_time) for f in feedback]
    assert all(b >= a for a, b in zip(elapsed, elapsed[1:])) and elapsed[-1] > elapsed[0], elapsed
    assert all(f.current_pose.header.frame_id == FRAME for f in feedback)
    last = feedback[-1].current_pose.pose.position
    assert math.hypot(last.x - 2.5, last.y) < 0.5, (last.x, last.y)
    print(f"navigate_to_pose: {len(feedback)} feedback messages, distance remaining {remaining[0]:.2f} -> "
          f"{remaining[-1]:.2f} m, estimated {eta[0]:.1f} -> {eta[-1]:.1f} s, navigation time {elapsed[-1]:.1f} s")


def test_back_up_reverses_three_decimetres(lab):
    start = lab.pose()
    backing = finish(lab, lab.nav2.send("backup", back_up(0.3)), 15.0)
    succeeded(backing)
    lab.run_for(1.0, wall_timeout_s=WALL_GUARD_S)    # the base brakes
    end = lab.pose()
    along = (end.x - start.x) * math.cos(start.yaw) + (end.y - start.y) * math.sin(start.yaw)
    assert along == pytest.approx(-0.3, abs=0.08), (start, end)
    travelled = [f.distance_traveled for _, f in backing.feedback]
    assert travelled and max(travelled) == pytest.approx(0.3, abs=0.08), travelled


def test_navigate_through_three_poses(lab):
    poses = [(3.2, 0.0, 0.0), (4.2, 0.0, 0.0), (5.2, 0.0, 0.0)]
    going = finish(lab, lab.nav2.send("navigate_through_poses", through(lab.nav2, poses)), 60.0)
    succeeded(going)
    assert near(lab, 5.2, 0.0, 0.25), lab.pose()
    left = [f.number_of_poses_remaining for _, f in going.feedback]
    assert left, "no feedback"
    assert all(b <= a for a, b in zip(left, left[1:])), left
    assert left[0] >= 2 and left[-1] <= 1, left


def test_follow_waypoints_skips_one_outside_the_map(lab):
    outside = (20.0, 0.0, 0.0)    # the global costmap spans 15 m either side of the start
    waypoints = [(6.2, 0.0, 0.0), outside, (7.2, 0.0, 0.0)]
    goal = FollowWaypoints.Goal(poses=[lab.nav2.pose(*w) for w in waypoints])
    following = finish(lab, lab.nav2.send("follow_waypoints", goal), 60.0)
    assert not following.rejected
    assert following.status in (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_ABORTED), following.status
    missed = following.result.missed_waypoints
    assert [m.index for m in missed] == [1], [(m.index, m.error_code) for m in missed]
    assert missed[0].goal.pose.position.x == pytest.approx(20.0) and missed[0].error_code != 0
    assert near(lab, 7.2, 0.0, 0.25), lab.pose()
    assert {f.current_waypoint for _, f in following.feedback} >= {0, 2}
    print(f"follow_waypoints: status {following.status}, missed {[(m.index, m.error_code) for m in missed]}, "
          f"error {following.result.error_code}: {following.result.error_msg!r}")


def test_a_goal_on_move_base_simple_preempts_navigate_to_pose(lab):
    start = lab.pose()
    first = lab.nav2.send("navigate_to_pose", navigate_to(lab.nav2, 2.0, 0.0, math.pi))  # behind: a U-turn
    lab.run_until(lab.time + 10.0, lambda: first.done or moved(lab, start) > 1.0, wall_timeout_s=WALL_GUARD_S)
    assert not first.done and moved(lab, start) > 1.0, "the first goal should be under way"
    lab.nav2.simple_goal.publish(lab.nav2.pose(5.5, 0.0, math.pi))
    finish(lab, first, 2.0)
    assert first.status == GoalStatus.STATUS_ABORTED, first.status
    assert "preempted" in first.result.error_msg.lower(), first.result.error_msg
    print(f"navigate_to_pose preempted: {first.result.error_msg!r}")
    # the robot drives to the new goal and stays there
    assert lab.run_until(lab.time + 40.0, lambda: near(lab, 5.5, 0.0, 0.2), wall_timeout_s=WALL_GUARD_S), lab.pose()
    lab.run_for(3.0, wall_timeout_s=WALL_GUARD_S)
    assert near(lab, 5.5, 0.0, 0.25), f"the robot went on past the new goal: {lab.pose()}"


def nan_pose(client):
    goal = navigate_to(client, 6.0, 0.0, 0.0)
    goal.pose.pose.position.y = math.nan
    return goal


#: (action, bad goal, a word the error must contain, a valid goal of the same kind that must work next)
BAD_INPUT = {
    "nan in the pose": ("navigate_to_pose", nan_pose, "pose", None),
    "unknown frame": ("navigate_to_pose", lambda c: navigate_to(c, 6.0, 0.0, 0.0, frame="mars"), "mars", None),
    "no poses": ("navigate_through_poses", lambda c: NavigateThroughPoses.Goal(), "poses", None),
    "10 000 poses": ("navigate_through_poses",
                     lambda c: through(c, [(5.0 + 1e-4 * i, 0.0, math.pi) for i in range(10_000)]), "poses", None),
    "negative back-up distance": ("backup", lambda c: back_up(-0.3), "target.x", lambda c: back_up(0.1)),
    "back-up without time": ("backup", lambda c: back_up(0.3, allowance=0.0), "time_allowance",
                             lambda c: back_up(0.1)),
    "spin of 1e9 rad": ("spin", lambda c: spin(1e9), "target_yaw", lambda c: spin(0.3)),
}


@pytest.mark.parametrize("case", BAD_INPUT)
def test_bad_input_is_aborted_naming_the_field_and_nothing_moves(lab, case):
    action, bad, word, valid = BAD_INPUT[case]
    start = lab.pose()
    refused = finish(lab, lab.nav2.send(action, bad(lab.nav2)), 10.0)
    assert not refused.rejected, "bad input should be accepted, then aborted"
    assert refused.status == GoalStatus.STATUS_ABORTED, refused.status
    assert word in refused.result.error_msg, refused.result.error_msg
    assert refused.result.error_code != 0, "a refusal must not read as success"
    print(f"{case}: {action} aborted, error {refused.result.error_code}: {refused.result.error_msg}")
    lab.run_for(1.0, wall_timeout_s=WALL_GUARD_S)
    assert moved(lab, start) < 0.02, f"the robot moved: {start} -> {lab.pose()}"
    # the same action takes the next, valid goal: where the robot stands, or a short behaviour
    here = lab.pose()
    if valid is None and action == "navigate_to_pose":
        nxt = navigate_to(lab.nav2, here.x, here.y, here.yaw)
    elif valid is None:
        nxt = through(lab.nav2, [(here.x, here.y, here.yaw)])
    else:
        nxt = valid(lab.nav2)
    succeeded(finish(lab, lab.nav2.send(action, nxt), 20.0))


def test_a_goal_after_the_bad_input_drives_there(lab):
    here = lab.pose()
    x = here.x - 1.0
    going = finish(lab, lab.nav2.send("navigate_to_pose", navigate_to(lab.nav2, x, 0.0, math.pi)), 30.0)
    succeeded(going)
    assert near(lab, x, 0.0, 0.25), lab.pose()
