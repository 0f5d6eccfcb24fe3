"""explore: slam.Explorer behind explore_lite's node: frontiers of the map become move_base goals until none is left.

In: the map on ``costmap_topic`` (latched), the robot's pose as TF (the map's frame -> ``robot_base_frame``).
Out: goals to the ``move_base`` action (explore_lite sends them the same way), ``~/frontiers`` (MarkerArray). When
no frontier is left, the map is saved through ``slam/save_map`` as ``save_map`` (YAML + image; the parameter's value
then: it may be set while exploring) and the node says so and idles. Services ``~/resume`` and ``~/stop``
(std_srvs/Empty) start and stop exploring, as explore_lite's ``explore/resume`` topic does.

What differs from explore_lite, for slam's map and the box robot (each is explained where it is done):
- before the first frontier, the robot turns once on the spot (LOOK_AROUND_TURNS);
- the map is searched as the robot's presence shows it: the unknown patch under it is free (slam.frontier.footprint_cleared);
- a frontier's goal is sent as a cell near it that is clear of walls and of the unknown, where the robot can turn
  and sees the goal (slam.frontier.goal_to_send); a frontier with no such cell is given up;
- a goal reached whose frontier a newer map still shows is given up at once, not after progress_timeout;
- when only given-up frontiers are left, those move_base failed or made no progress to are tried once more.
``goals_sent``, ``goals_failed`` (by move_base) and ``goals_given_up`` (all reasons) count what it did.
"""

from __future__ import annotations

import math
import sys

from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Point
from nav2_msgs.srv import SaveMap
from nav_msgs.msg import OccupancyGrid
from rclpy.action import ActionClient
from rclpy.time import Time
from std_srvs.srv import Empty
from visualization_msgs.msg import Marker, MarkerArray

from move_base_msgs.action import MoveBase
from simplebot_navigation.maps.map_io import OccupancyMap
from simplebot_navigation.parameters import ParameterError, fields_of
from simplebot_navigation.ros.conversions import checked_occupancy_map, quaternion_msg, transform_to_xyyaw
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree, take_live_changes
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.qos import LATCHED, SERVICE_QOS
from simplebot_navigation.ros.tf import Buffer, TransformException, TransformListener, strip_frame
from simplebot_navigation.slam.frontier import Explorer, find_frontiers, footprint_cleared, goal_to_send
from simplebot_navigation.slam.params import ExploreParams


#: before exploring, the robot turns once on the spot in this many steps (move_base goals): slam marks a cell free
#: only once several scans from distinct poses saw through it, so the first map shows nothing free
LOOK_AROUND_TURNS = 3
#: seconds a goal reached may be chosen again before it is given up (if no newer map came)
REACHED_WAIT = 5.0


class ExploreNode(SetUpNode):
    def __init__(self, **kwargs):
        kwargs.setdefault("automatically_declare_parameters_from_overrides", True)
        super().__init__("explore", **kwargs)

    def _set_up(self) -> None:
        self.params = p = ExploreParams.from_params(given_parameter_tree(self))
        for warning in p.warnings:
            self.get_logger().warn(warning)
        specs = fields_of(ExploreParams)
        declare_defaults(self, {name: getattr(p, name) for name in specs}, specs=specs)
        self.explorer = self._new_explorer()
        #: goals given up because move_base failed them or made no progress (it may have been stuck for a while),
        #: and those of them tried once more
        self._retryable: set[tuple[float, float]] = set()
        self._retried: set[tuple[float, float]] = set()
        self.base_frame = strip_frame(p.robot_base_frame)
        self.map = None
        self.goal: tuple[float, float] | None = None
        self._handle = None
        self.running, self.finished = True, False
        #: goals sent to move_base, those it failed, and all goals given up (those, and those without progress)
        self.goals_sent = self.goals_failed = self.goals_given_up = 0
        self._turning, self._turns = False, 0       # a goal to turn on the spot (not a frontier's), and how many sent
        self._looked_around: list[tuple[float, float]] = []       # where it turned
        self._frontier_goal: tuple[float, float] | None = None      # the Explorer's goal for self.goal
        self._maps_seen = 0
        #: the last goal reached: the Explorer's goal, the place sent to, _maps_seen and the time then
        self._reached: tuple[tuple[float, float], tuple[float, float], int, float] | None = None
        self.tf = Buffer(node=self)
        self._listener = TransformListener(self.tf, self)
        self.action = ActionClient(self, MoveBase, "move_base", goal_service_qos_profile=SERVICE_QOS,
                                   result_service_qos_profile=SERVICE_QOS, cancel_service_qos_profile=SERVICE_QOS)
        self.save_client = self.create_client(SaveMap, "slam/save_map", qos_profile=SERVICE_QOS)
        self.markers_pub = create_publisher(self, MarkerArray, "~/frontiers", 1)
        self.create_subscription(OccupancyGrid, p.costmap_topic, self._on_map, LATCHED)
        self.create_service(Empty, "~/resume", self._on_resume, qos_profile=SERVICE_QOS)
        self.create_service(Empty, "~/stop", self._on_stop, qos_profile=SERVICE_QOS)
        self._timer = self.create_timer(1.0 / p.planner_frequency, self._plan)
        take_live_changes(self, specs, "explore", self._take_parameters)
        self.get_logger().info(f"exploring the frontiers of {self.resolve_topic_name(p.costmap_topic)}")

    def _take_parameters(self, changes: dict) -> None:
        """A live change (already checked against its spec): the Explorer is rebuilt with the new values and keeps
        the goals given up; a new planner_frequency restarts the search's timer. A parameter without effect here
        warns, as at start-up."""
        specs = fields_of(ExploreParams)
        new = ExploreParams.from_params({**{name: getattr(self.params, name) for name in specs}, **changes})
        for name in changes:
            if not specs[name].implemented:
                self.get_logger().warn(specs[name].warning(f"explore/{name}"))
        old, self.params = self.params, new
        self.explorer = self._new_explorer(self.explorer.blacklist)
        if new.planner_frequency != old.planner_frequency:
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / new.planner_frequency, self._plan)
        self.get_logger().info("parameters changed: " + ", ".join(f"{k}={v!r}" for k, v in changes.items()))

    def _on_map(self, msg: OccupancyGrid) -> None:
        try:
            self.map = checked_occupancy_map(msg, "explore")
            self._maps_seen += 1
        except ValueError as err:
            self.get_logger().warn(f"map ignored: {err}")

    def _robot_pose(self) -> tuple[float, float, float] | None:
        try:
            tf = self.tf.lookup_transform(strip_frame(self.map.frame_id) or "map", self.base_frame, Time())
        except TransformException as err:
            self.get_logger().warn(f"no robot pose in the map: {err}", throttle_duration_sec=10.0)
            return None
        age = (self.get_clock().now() - Time.from_msg(tf.header.stamp)).nanoseconds * 1e-9
        if age > self.params.transform_tolerance + 1.0 / self.params.planner_frequency:
            self.get_logger().warn(f"the robot's pose in the map is {age:.2f} s old", throttle_duration_sec=10.0)
        return transform_to_xyyaw(tf)

    def _plan(self) -> None:
        """explore_lite's makePlan: the cheapest frontier's goal, sent when it changes; done when none is left. First
        the robot turns on the spot (LOOK_AROUND_TURNS), as the map shows nothing free until slam has a few scans."""
        if not self.running or self.map is None or not self.action.server_is_ready():
            return
        pose = self._robot_pose()
        if pose is None:
            return
        if self._turning and self.goal is not None:
            return
        if self._turns < LOOK_AROUND_TURNS:
            self._turns += 1
            self.get_logger().info(f"looking around: turn {self._turns} of {LOOK_AROUND_TURNS} on the spot")
            self._send(pose[:2], pose[2] + 2.0 * math.pi / LOOK_AROUND_TURNS, turning=True)
            if not any(math.dist(pose[:2], spot) < self.params.clearance for spot in self._looked_around):
                self._looked_around.append(pose[:2])
            return
        robot = pose[:2]
        grid = footprint_cleared(self.map, robot, self._looked_around, self.params.clearance)
        now = self.get_clock().now().nanoseconds * 1e-9
        try:
            given_up = len(self.explorer.blacklist)
            goal = self.explorer.next_goal(grid, robot, now)
            if len(self.explorer.blacklist) > given_up:
                self.goals_given_up += 1
                self._retryable.add(self.explorer.blacklist[-1])
                self.get_logger().info(f"no progress towards the goal for {self.params.progress_timeout:g} s: given up")
            if self.params.visualize and self.markers_pub.get_subscription_count():
                self._publish_frontiers(grid, robot)
        except ValueError as err:
            self.get_logger().warn(f"frontier search skipped: {err}", throttle_duration_sec=10.0)
            return
        if goal is None:
            if not self._retry_given_up():
                self._finish()
            return
        target = goal_to_send(grid, goal, self.params.clearance)
        if self._reached is not None and (math.dist(goal, self._reached[0]) < grid.resolution / 2 or (
                target is not None and math.dist(target, self._reached[1]) < grid.resolution / 2)):
            self._reached_again(goal, now)
            return
        if target is None:
            self.get_logger().info(f"the frontier at ({goal[0]:.2f}, {goal[1]:.2f}) lies in a nook, seen from nowhere "
                                   "the robot can turn: given up")
            self.goals_given_up += 1
            self.explorer.goal_failed(goal)
            self._plan()
            return
        if self.goal is None or math.dist(target, self.goal) > 1e-6:
            self._send(target, math.atan2(target[1] - robot[1], target[0] - robot[0]), frontier_goal=goal)

    def _reached_again(self, goal: tuple[float, float], now: float) -> None:
        """The goal just reached (or the place it was sent to) is chosen again: explore_lite waits (it never sends a
        goal twice) until a newer map changes it, or gives it up after progress_timeout. Here it is given up once a
        map drawn since the robot got there still has its frontier, or REACHED_WAIT seconds passed without one (slam
        adds no scan while the robot stands)."""
        if self._maps_seen <= self._reached[2] and now - self._reached[3] < REACHED_WAIT:
            return
        self.get_logger().info(f"goal ({goal[0]:.2f}, {goal[1]:.2f}) reached, but its frontier is still on the map "
                               "drawn since: given up")
        self._reached = None
        self.goals_given_up += 1
        self.explorer.goal_failed(goal)
        self._plan()

    def _new_explorer(self, blacklist=()) -> Explorer:
        p = self.params
        explorer = Explorer(p.min_frontier_size, p.potential_scale, p.gain_scale, p.clearance, p.progress_timeout,
                            p.blacklist_radius)
        for goal in blacklist:
            explorer.goal_failed(goal)
        return explorer

    def _retry_given_up(self) -> bool:
        """No frontier is left but those given up: explore_lite stops here. A goal given up because move_base failed
        it or made no progress (stuck for a while, or before the map showed the way) may be reachable now, so each is
        tried once more first; not those reached, nor those in a nook."""
        fresh = [goal for goal in self.explorer.blacklist if goal in self._retryable - self._retried]
        if not fresh:
            return False
        self.get_logger().info(f"no frontier left but {len(fresh)} given up while move_base was stuck or failed: "
                               "trying them once more")
        self._retried.update(fresh)
        self.explorer = self._new_explorer([goal for goal in self.explorer.blacklist if goal not in fresh])
        return True

    def _send(self, goal: tuple[float, float], yaw: float, turning: bool = False, frontier_goal=None) -> None:
        self.goal, self.finished, self._turning = goal, False, turning
        self._frontier_goal = frontier_goal or goal
        self.goals_sent += not turning
        msg = MoveBase.Goal()
        msg.target_pose.header.frame_id = self.map.frame_id or "map"
        msg.target_pose.header.stamp = self.get_clock().now().to_msg()
        msg.target_pose.pose.position.x, msg.target_pose.pose.position.y = goal
        msg.target_pose.pose.orientation = quaternion_msg(yaw)
        if not turning:
            self.get_logger().info(f"exploring towards ({goal[0]:.2f}, {goal[1]:.2f})")
        self.action.send_goal_async(msg).add_done_callback(lambda future: self._on_accepted(goal, future))

    def _on_accepted(self, goal, future) -> None:
        handle = future.result()
        if not handle.accepted:
            self._on_result(goal, GoalStatus.STATUS_ABORTED)
            return
        self._handle = handle
        handle.get_result_async().add_done_callback(lambda result: self._on_result(goal, result.result().status))

    def _on_result(self, goal, status: int) -> None:
        """A goal that move_base could not reach is given up (explore_lite blacklists it); any end means re-plan."""
        if status == GoalStatus.STATUS_SUCCEEDED and self.goal == goal and not self._turning:
            self._reached = (self._frontier_goal, goal, self._maps_seen, self.get_clock().now().nanoseconds * 1e-9)
        elif status != GoalStatus.STATUS_SUCCEEDED and self.goal == goal and not self._turning:
            self.get_logger().info(f"goal ({goal[0]:.2f}, {goal[1]:.2f}) not reached (status {status}): given up")
            self.goals_failed += 1
            self.goals_given_up += 1
            self._retryable.add(self._frontier_goal)
            self.explorer.goal_failed(self._frontier_goal)
        if self.goal == goal:
            self.goal = None
            if self.running:
                self._plan()

    def _finish(self) -> None:
        if self.finished:
            return
        self.finished, self.goal = True, None
        self.get_logger().info("exploration done: no frontier left")
        name = self.params.save_map         # as set now (ros2 param set), not only at start
        if not name:
            return
        if not self.save_client.service_is_ready():
            self.get_logger().error("exploration done, but slam/save_map is not there: the map is not saved")
            return
        self.save_client.call_async(SaveMap.Request(map_url=name)).add_done_callback(
            lambda future: self.get_logger().info(f"map saved as {name}.yaml")
            if future.result().result else self.get_logger().error(
                f"slam/save_map could not write {name}.yaml (see slam's log)"))

    def _publish_frontiers(self, grid: OccupancyMap, robot) -> None:
        p = self.params
        frontiers = find_frontiers(grid, robot, p.min_frontier_size, p.potential_scale, p.gain_scale, p.clearance)
        marker = Marker(id=0, type=Marker.SPHERE_LIST, action=Marker.ADD, ns="frontiers")
        marker.header.frame_id = self.map.frame_id or "map"
        marker.header.stamp = self.get_clock().now().to_msg()
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = marker.scale.z = 0.25
        marker.color.r, marker.color.g, marker.color.a = 1.0, 0.5, 1.0
        marker.points = [Point(x=float(f.goal[0]), y=float(f.goal[1])) for f in frontiers]
        self.markers_pub.publish(MarkerArray(markers=[marker]))

    def _on_resume(self, _request, response):
        self.running, self.finished = True, False
        self.get_logger().info("exploration resumed")
        return response

    def _on_stop(self, _request, response):
        self.running = False
        if self._handle is not None:
            self._handle.cancel_goal_async()
        self.goal = None
        self.get_logger().info("exploration stopped")
        return response


def main(args=None) -> int:
    return run_node("explore", ExploreNode, args, (ValueError, ParameterError))


if __name__ == "__main__":
    sys.exit(main())
