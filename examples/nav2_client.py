"""Drive simplebot through Nav2's front door: move_base serves Nav2's actions and services (nav2_msgs).

This client knows nothing of simplebot_navigation: it is plain rclpy on nav2_msgs, as for any Nav2 robot.
Start the stack in one shell, then run this in another (same ROS_DOMAIN_ID)::

    python -m simplebot_navigation.launch navigation
    python examples/nav2_client.py 2.5 0.0 [--yaw 0.0] [--frame odom] [--namespace robot1]

It waits until bt_navigator is active, asks for a path to the goal (ComputePathToPose: nothing moves), drives
there (NavigateToPose, printing the feedback), backs up 0.3 m (BackUp) and clears both costmaps. Ctrl-C while the
robot drives cancels the goal. The exit code is 0 if every step succeeded.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import rclpy
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.srv import GetState
from nav2_msgs.action import BackUp, ComputePathToPose, NavigateToPose
from nav2_msgs.srv import ClearEntireCostmap
from rclpy.action import ActionClient
from rclpy.node import Node


def seconds(duration: Duration) -> float:
    return duration.sec + duration.nanosec * 1e-9


class Nav2Client(Node):
    """NavigateToPose, ComputePathToPose and BackUp, bt_navigator's state and the costmaps' clearing."""

    def __init__(self, namespace: str = "", frame: str = "odom"):
        super().__init__("nav2_client_example", namespace=namespace)
        self.frame = frame
        self.navigate = ActionClient(self, NavigateToPose, "navigate_to_pose")
        self.plan = ActionClient(self, ComputePathToPose, "compute_path_to_pose")
        self.backup = ActionClient(self, BackUp, "backup")
        self.state = self.create_client(GetState, "bt_navigator/get_state")
        self.clear = [self.create_client(ClearEntireCostmap, name) for name in
                      ("global_costmap/clear_entirely_global_costmap", "local_costmap/clear_entirely_local_costmap")]

    # -- helpers -------------------------------------------------------------------------------------------------
    def wait_for(self, future, timeout_s: float | None = None):
        """Spin until the future is done; its result (None on timeout)."""
        rclpy.spin_until_future_complete(self, future, timeout_sec=timeout_s)
        return future.result() if future.done() else None

    def pose(self, x: float, y: float, yaw: float) -> PoseStamped:
        msg = PoseStamped()
        msg.header.frame_id = self.frame    # stamp 0: the latest transform (the stack runs on simulated time)
        msg.pose.position.x, msg.pose.position.y = x, y
        msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        return msg

    def run(self, client: ActionClient, goal, feedback=None):
        """Send a goal and wait for its end: (status, result); (None, None) if it was not accepted."""
        handle = self.wait_for(client.send_goal_async(goal, feedback_callback=feedback))
        if handle is None or not handle.accepted:
            return None, None
        try:
            done = self.wait_for(handle.get_result_async())
        except KeyboardInterrupt:
            print("cancelling the goal")
            self.wait_for(handle.cancel_goal_async(), timeout_s=5.0)
            raise
        return done.status, done.result

    # -- the steps -------------------------------------------------------------------------------------------
    def wait_until_active(self, timeout_s: float = 60.0) -> bool:
        """bt_navigator's lifecycle state is "active" once move_base takes goals."""
        deadline = time.monotonic() + timeout_s
        if not self.state.wait_for_service(timeout_sec=timeout_s):
            return False
        while time.monotonic() < deadline:
            response = self.wait_for(self.state.call_async(GetState.Request()), timeout_s=5.0)
            if response is not None and response.current_state.label == "active":
                return True
            time.sleep(0.5)
        return False

    def compute_path(self, x: float, y: float, yaw: float) -> bool:
        self.plan.wait_for_server()
        status, result = self.run(self.plan, ComputePathToPose.Goal(goal=self.pose(x, y, yaw)))
        if status != GoalStatus.STATUS_SUCCEEDED:
            print(f"no path: {result.error_msg if result else 'goal not accepted'}")
            return False
        points = [(p.pose.position.x, p.pose.position.y) for p in result.path.poses]
        length = sum(math.dist(a, b) for a, b in zip(points, points[1:]))
        print(f"path: {len(points)} poses, {length:.2f} m in {result.path.header.frame_id}, "
              f"planned in {seconds(result.planning_time) * 1e3:.0f} ms")
        return True

    def navigate_to(self, x: float, y: float, yaw: float) -> bool:
        shown = [-math.inf]      # navigation_time of the last line printed

        def show(msg):           # feedback comes every control cycle: a line a second
            f = msg.feedback
            if seconds(f.navigation_time) < shown[0] + 1.0:
                return
            shown[0] = seconds(f.navigation_time)
            p = f.current_pose.pose.position
            print(f"  at ({p.x:5.2f}, {p.y:5.2f})  {f.distance_remaining:5.2f} m to go, "
                  f"about {seconds(f.estimated_time_remaining):4.1f} s left, "
                  f"{seconds(f.navigation_time):5.1f} s under way, {f.number_of_recoveries} recoveries")

        self.navigate.wait_for_server()
        print(f"navigating to ({x}, {y}, yaw {yaw}) in {self.frame}")
        status, result = self.run(self.navigate, NavigateToPose.Goal(pose=self.pose(x, y, yaw)), show)
        if status != GoalStatus.STATUS_SUCCEEDED:
            print(f"navigation failed (status {status}): {result.error_msg if result else 'goal not accepted'}")
            return False
        print("goal reached")
        return True

    def back_up(self, distance: float = 0.3, speed: float = 0.15) -> bool:
        goal = BackUp.Goal(speed=speed, time_allowance=Duration(sec=10))
        goal.target.x = distance
        self.backup.wait_for_server()
        status, result = self.run(self.backup, goal)
        if status != GoalStatus.STATUS_SUCCEEDED:
            print(f"back-up failed: {result.error_msg if result else 'goal not accepted'}")
            return False
        print(f"backed up {distance} m in {seconds(result.total_elapsed_time):.1f} s")
        return True

    def clear_costmaps(self) -> bool:
        for client in self.clear:
            if not client.wait_for_service(timeout_sec=5.0) or \
                    self.wait_for(client.call_async(ClearEntireCostmap.Request()), timeout_s=5.0) is None:
                print(f"{client.srv_name} did not answer")
                return False
            print(f"cleared {client.srv_name}")
        return True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Send simplebot a goal through Nav2's actions (the stack must "
                                                 "be running: python -m simplebot_navigation.launch navigation)")
    parser.add_argument("x", type=float, help="goal x (m)")
    parser.add_argument("y", type=float, help="goal y (m)")
    parser.add_argument("--yaw", type=float, default=0.0, help="goal heading (rad), default 0")
    parser.add_argument("--frame", default="odom", help="the goal's frame: odom (default), or map on a map")
    parser.add_argument("--namespace", default="", help="the robot's namespace (multi_navigation: robot1, ...)")
    args = parser.parse_args(argv)

    rclpy.init()
    client = Nav2Client(args.namespace, args.frame)
    try:
        if not client.wait_until_active():
            print("bt_navigator is not active: is `python -m simplebot_navigation.launch navigation` running?")
            return 1
        ok = (client.compute_path(args.x, args.y, args.yaw) and client.navigate_to(args.x, args.y, args.yaw)
              and client.back_up() and client.clear_costmaps())
        return 0 if ok else 1
    except KeyboardInterrupt:
        return 130
    finally:
        client.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
