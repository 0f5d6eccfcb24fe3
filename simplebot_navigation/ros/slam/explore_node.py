"""explore: slam.Explorer behind explore_lite's node: frontiers of the map become move_base goals until none is left.

In: the map on ``costmap_topic`` (latched), the robot's pose as TF (the map's frame -> ``robot_base_frame``).
Out: goals to the ``move_base`` action (explore_lite sends them the same way), ``~/frontiers`` (MarkerArray). When
no frontier is left, the map is saved through ``slam/save_map`` as ``save_map`` (YAML + image) and the node says so
and idles. Services ``~/resume`` and ``~/stop`` (std_srvs/Empty) start and stop exploring, as explore_lite's
``explore/resume`` topic does.
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
from simplebot_navigation.parameters import ParameterError, fields_of
from simplebot_navigation.ros.conversions import checked_occupancy_map, quaternion_msg, transform_to_xyyaw
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.qos import LATCHED, SERVICE_QOS
from simplebot_navigation.ros.tf import Buffer, TransformException, TransformListener, strip_frame
from simplebot_navigation.slam.frontier import Explorer, find_frontiers
from simplebot_navigation.slam.params import ExploreParams


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
        self.explorer = Explorer(p.min_frontier_size, p.potential_scale, p.gain_scale, p.clearance,
                                 p.progress_timeout, p.blacklist_radius)
        self.base_frame = strip_frame(p.robot_base_frame)
        self.map = None
        self.goal: tuple[float, float] | None = None
        self._handle = None
        self.running, self.finished = True, False
        self.tf = Buffer(node=self)
        self._listener = TransformListener(self.tf, self)
        self.action = ActionClient(self, MoveBase, "move_base", goal_service_qos_profile=SERVICE_QOS,
                                   result_service_qos_profile=SERVICE_QOS, cancel_service_qos_profile=SERVICE_QOS)
        self.save_client = self.create_client(SaveMap, "slam/save_map", qos_profile=SERVICE_QOS)
        self.markers_pub = create_publisher(self, MarkerArray, "~/frontiers", 1)
        self.create_subscription(OccupancyGrid, p.costmap_topic, self._on_map, LATCHED)
        self.create_service(Empty, "~/resume", self._on_resume, qos_profile=SERVICE_QOS)
        self.create_service(Empty, "~/stop", self._on_stop, qos_profile=SERVICE_QOS)
        self.create_timer(1.0 / p.planner_frequency, self._plan)
        self.get_logger().info(f"exploring the frontiers of {self.resolve_topic_name(p.costmap_topic)}")

    def _on_map(self, msg: OccupancyGrid) -> None:
        try:
            self.map = checked_occupancy_map(msg, "explore")
        except ValueError as err:
            self.get_logger().warn(f"map ignored: {err}")

    def _robot_xy(self) -> tuple[float, float] | None:
        try:
            tf = self.tf.lookup_transform(strip_frame(self.map.frame_id) or "map", self.base_frame, Time())
        except TransformException as err:
            self.get_logger().warn(f"no robot pose in the map: {err}", throttle_duration_sec=10.0)
            return None
        age = (self.get_clock().now() - Time.from_msg(tf.header.stamp)).nanoseconds * 1e-9
        if age > self.params.transform_tolerance + 1.0 / self.params.planner_frequency:
            self.get_logger().warn(f"the robot's pose in the map is {age:.2f} s old", throttle_duration_sec=10.0)
        return transform_to_xyyaw(tf)[:2]

    def _plan(self) -> None:
        """explore_lite's makePlan: the cheapest frontier's goal, sent when it changes; done when none is left."""
        if not self.running or self.map is None or not self.action.server_is_ready():
            return
        robot = self._robot_xy()
        if robot is None:
            return
        now = self.get_clock().now().nanoseconds * 1e-9
        try:
            goal = self.explorer.next_goal(self.map, robot, now)
            if self.params.visualize and self.markers_pub.get_subscription_count():
                self._publish_frontiers(robot)
        except ValueError as err:
            self.get_logger().warn(f"frontier search skipped: {err}", throttle_duration_sec=10.0)
            return
        if goal is None:
            self._finish()
        elif self.goal is None or math.dist(goal, self.goal) > 1e-6:
            self._send(goal, robot)

    def _send(self, goal: tuple[float, float], robot: tuple[float, float]) -> None:
        self.goal, self.finished = goal, False
        msg = MoveBase.Goal()
        msg.target_pose.header.frame_id = self.map.frame_id or "map"
        msg.target_pose.header.stamp = self.get_clock().now().to_msg()
        msg.target_pose.pose.position.x, msg.target_pose.pose.position.y = goal
        msg.target_pose.pose.orientation = quaternion_msg(math.atan2(goal[1] - robot[1], goal[0] - robot[0]))
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
        if status != GoalStatus.STATUS_SUCCEEDED and self.goal == goal:
            self.get_logger().info(f"goal ({goal[0]:.2f}, {goal[1]:.2f}) not reached (status {status}): given up")
            self.explorer.goal_failed(goal)
        if self.goal == goal:
            self.goal = None
            if self.running:
                self._plan()

    def _finish(self) -> None:
        if self.finished:
            return
        self.finished, self.goal = True, None
        self.get_logger().info("exploration done: no frontier left")
        if not self.params.save_map:
            return
        if not self.save_client.service_is_ready():
            self.get_logger().error("exploration done, but slam/save_map is not there: the map is not saved")
            return
        request = SaveMap.Request(map_url=self.params.save_map)
        self.save_client.call_async(request).add_done_callback(
            lambda future: self.get_logger().info(f"map saved as {self.params.save_map}.yaml")
            if future.result().result else self.get_logger().error(
                f"slam/save_map could not write {self.params.save_map}.yaml (see slam's log)"))

    def _publish_frontiers(self, robot) -> None:
        p = self.params
        frontiers = find_frontiers(self.map, robot, p.min_frontier_size, p.potential_scale, p.gain_scale, p.clearance)
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
