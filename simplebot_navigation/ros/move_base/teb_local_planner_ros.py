"""TebLocalPlannerROS: the ROS shell move_base owns around the pure TebLocalPlanner.

It converts the global plan into the local costmap's frame, feeds odometry and moving obstacles (move_base's
obstacle feed, docs/reference.md §6.3), holds the local costmap's lock while planning, and
publishes what the lab visualises (docs/reference.md §4.6). The
visualisation has its own timer, so building markers and paths never delays a velocity command,
and costs nothing while no one subscribes.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Point, PoseArray
from nav_msgs.msg import Odometry, Path
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.geometry import transform_points
from simplebot_navigation.move_base.plugins import plugin_namespace
from simplebot_navigation.move_base.plugins import ControlResult
from simplebot_navigation.parameters import fields_of, values_of
from simplebot_navigation.ros.conversions import path_msg, pose_array_msg, transform_to_xyyaw
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.tf import Buffer, TransformException
from simplebot_navigation.teb import TebConfig, TebLocalPlanner, warm_up

ODOM_STALE_S = 1.0


class TebLocalPlannerROS:
    """move_base's LocalPlannerPlugin (move_base/plugins.py) around the pure TebLocalPlanner."""

    def __init__(self, node: Node, plugin_type: str, costmap_ros, tf_buffer: Buffer, controller_frequency: float,
                 plan_frame: str, obstacle_feed):
        self.obstacle_feed = obstacle_feed
        self.name = plugin_namespace(plugin_type)
        self.plan_frame = plan_frame
        self._plan: np.ndarray | None = None    # the latest global plan, in plan_frame
        self._pose = None                       # the robot pose of this control cycle (begin_cycle)
        self.node = node
        self.costmap_ros = costmap_ros
        self.tf = tf_buffer
        self.logger = node.get_logger()
        self.config = TebConfig.from_params(given_parameter_tree(node, self.name))
        self.planner = TebLocalPlanner(self.config, costmap_ros.footprint, 1.0 / controller_frequency)
        warm_up()  # compiled kernels loaded now, not in the first control cycle of the first goal
        for warning in self.planner.warnings:
            self.logger.warn(warning)
        declare_defaults(node, values_of(self.config), self.name, specs=fields_of(TebConfig))
        self.frame = costmap_ros.global_frame
        base = f"~/{self.name}"
        self.local_plan_pub = create_publisher(node, Path, f"{base}/local_plan", 1)
        self.global_plan_pub = create_publisher(node, Path, f"{base}/global_plan", 1)
        self.poses_pub = create_publisher(node, PoseArray, f"{base}/teb_poses", 1)
        self.markers_pub = create_publisher(node, MarkerArray, f"{base}/teb_markers", 1)
        self.odom_topic = self.config.odom_topic
        self._velocity = (0.0, 0.0)
        self._odom_time: float | None = None  # node clock (sim time), so lockstep runs do not depend on wall speed
        node.create_subscription(Odometry, self.odom_topic, self._on_odom, 10)
        self._unpublished = False
        self._publish_timer = node.create_timer(1.0 / controller_frequency, self._publish)

    # -- run-time changes (move_base's live parameters) ---------------------------------------------
    def reconfigure(self, config: TebConfig) -> None:
        """New TebLocalPlannerROS parameters, used from the next control cycle."""
        self.planner.reconfigure(config)

    def set_controller_frequency(self, controller_frequency: float) -> None:
        self.planner.set_controller_period(1.0 / controller_frequency)
        self._publish_timer.timer_period_ns = round(1e9 / controller_frequency)
        self._publish_timer.reset()

    def set_costmap_footprint(self, footprint) -> None:
        """The local costmap's footprint changed (its footprint, robot_radius or padding)."""
        self.planner.set_costmap_footprint(footprint)

    # -- odometry -------------------------------------------------------------------------------
    def _on_odom(self, msg: Odometry) -> None:
        v, w = msg.twist.twist.linear.x, msg.twist.twist.angular.z
        if math.isfinite(v) and math.isfinite(w):
            self._velocity = (v, w)
            self._odom_time = self._now()

    def _robot_velocity(self) -> tuple[float, float]:
        if self._odom_time is None or self._now() - self._odom_time > ODOM_STALE_S:
            self.logger.warn(f"no odometry on {self.odom_topic} (odom_topic): planning from zero velocity",
                             throttle_duration_sec=10.0)
            return (0.0, 0.0)
        return self._velocity

    def _now(self) -> float:
        return self.node.get_clock().now().nanoseconds / 1e9

    # -- the controller interface of move_base ---------------------------------------------------
    def set_plan(self, plan: np.ndarray) -> bool:
        """Take a global plan ((N, 3) in plan_frame); the planner gets it in the local costmap frame, by the
        latest transform, and again at every cycle (as TEB's transformGlobalPlan), since map -> odom moves."""
        in_frame = self._in_local_frame(plan)
        if in_frame is None:
            return False
        self._plan = plan
        self.planner.set_plan(in_frame)
        return True

    def _in_local_frame(self, plan: np.ndarray) -> np.ndarray | None:
        if self.plan_frame == self.frame:
            return plan
        try:
            tf = self.tf.lookup_transform(self.frame, self.plan_frame, Time(), Duration(seconds=0.0))
        except TransformException as err:
            self.logger.error(f"Could not transform the global plan to the frame of the controller: {err}",
                              throttle_duration_sec=2.0)
            return None
        return transform_points(transform_to_xyyaw(tf), plan, dtype=plan.dtype)

    def begin_cycle(self, pose) -> None:
        """The cycle's robot pose in the local costmap's frame; the plan follows the latest map -> odom, once."""
        self._pose = pose
        if self.plan_frame != self.frame and self._plan is not None:
            in_frame = self._in_local_frame(self._plan)
            if in_frame is not None:
                self.planner.move_plan(in_frame)

    def reset(self) -> None:
        self.planner.reset()

    def compute(self) -> ControlResult:
        pose = self._pose
        if pose is None:
            return ControlResult(False, message=f"no robot pose: {self.costmap_ros.last_pose_error}")
        moving = self.obstacle_feed.moving_obstacles(self._now(), self.frame)
        self.planner.set_dynamic_obstacles(moving.rows, moving.covariance)
        with self.costmap_ros.lock:
            result = self.planner.compute_velocity_commands(pose[:3], self._robot_velocity(),
                                                            self.costmap_ros.costmap)
        self._unpublished = True
        log_notices(self.logger, self.planner.pop_notices())
        return ControlResult(result.ok, result.v, result.omega, result.message)

    def is_goal_reached(self) -> bool:
        pose = self._pose
        return pose is not None and self.planner.is_goal_reached(pose[:3], self._robot_velocity())

    # -- visualisation ------------------------------------------------------------------------
    def _publish(self) -> None:
        """The band, plan and markers of the latest control cycle, to the topics someone listens to."""
        if not self._unpublished:
            return
        self._unpublished = False
        stamp = self.node.get_clock().now().to_msg()
        band = self.planner.band_poses
        if self.local_plan_pub.get_subscription_count():
            self.local_plan_pub.publish(path_msg(band, self.frame, stamp))
        if self.global_plan_pub.get_subscription_count():
            self.global_plan_pub.publish(path_msg(self.planner.transformed_plan, self.frame, stamp))
        if self.poses_pub.get_subscription_count():
            self.poses_pub.publish(pose_array_msg(band, self.frame, stamp))
        if self.markers_pub.get_subscription_count() == 0:
            return
        obstacles = Marker(ns="PointObstacles", id=0, type=Marker.POINTS, action=Marker.ADD)
        obstacles.scale.x = obstacles.scale.y = 0.1
        obstacles.color = ColorRGBA(r=1.0, a=1.0)
        obstacles.points = [Point(x=float(x), y=float(y)) for x, y in self.planner.obstacles]
        footprint = Marker(ns="FootprintModel", id=0, type=Marker.LINE_LIST, action=Marker.ADD)
        footprint.scale.x = 0.01
        footprint.color = ColorRGBA(b=1.0, a=0.8)
        for outlines in self.planner.footprint_outlines():
            for outline in outlines:
                for (x0, y0), (x1, y1) in zip(outline[:-1], outline[1:]):
                    footprint.points += [Point(x=float(x0), y=float(y0)), Point(x=float(x1), y=float(y1))]
        for marker in (obstacles, footprint):
            marker.header.frame_id = self.frame
            marker.header.stamp = stamp
        self.markers_pub.publish(MarkerArray(markers=[obstacles, footprint]))


def log_notices(logger, notices) -> None:
    """The planner's (level, message) notices, one call site per severity: rclpy raises when the
    severity of a call site changes between calls."""
    for level, notice in notices:
        if level == "warn":
            logger.warn(notice)
        else:
            logger.info(notice)
