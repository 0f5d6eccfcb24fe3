"""MPPILocalPlannerROS: the ROS shell move_base owns around the pure MppiController (docs/reference.md §4.10).

It moves the global plan into the local costmap's frame, feeds odometry and the moving obstacles of move_base's
obstacle feed, holds the local costmap's lock while the cycle reads it, and publishes the trajectory the command
starts as ``~/MPPILocalPlannerROS/local_plan``, from its own timer and only while someone subscribes.
"""

from __future__ import annotations

import math

import numpy as np
from nav_msgs.msg import Odometry, Path
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time

from simplebot_navigation.geometry import transform_points
from simplebot_navigation.move_base.plugins import ControlResult, plugin_namespace
from simplebot_navigation.mppi import MppiConfig, MppiController, warm_up
from simplebot_navigation.parameters import fields_of, values_of
from simplebot_navigation.ros.conversions import path_msg, transform_to_xyyaw
from simplebot_navigation.ros.move_base.teb_local_planner_ros import ODOM_STALE_S, log_notices
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.tf import Buffer, TransformException


class MPPILocalPlannerROS:
    """move_base's LocalPlannerPlugin (move_base/plugins.py) around the pure MppiController."""

    def __init__(self, node: Node, plugin_type: str, costmap_ros, tf_buffer: Buffer, controller_frequency: float,
                 plan_frame: str, obstacle_feed):
        self.node = node
        self.name = plugin_namespace(plugin_type)
        self.costmap_ros = costmap_ros
        self.tf = tf_buffer
        self.plan_frame = plan_frame
        self.obstacle_feed = obstacle_feed
        self.logger = node.get_logger()
        self.frame = costmap_ros.global_frame
        self.config = MppiConfig.from_params(given_parameter_tree(node, self.name))
        for warning in self.config.warnings:
            self.logger.warn(warning)
        self.controller = MppiController(self.config, costmap_ros.footprint, 1.0 / controller_frequency)
        warm_up()  # compiled kernels loaded now, not in the first control cycle of the first goal
        declare_defaults(node, values_of(self.config), self.name, specs=fields_of(MppiConfig))
        self._plan: np.ndarray | None = None
        self._pose = None
        self.odom_topic = self.config.odom_topic
        self._velocity = (0.0, 0.0)
        self._odom_time: float | None = None
        node.create_subscription(Odometry, self.odom_topic, self._on_odom, 10)
        self.local_plan_pub = create_publisher(node, Path, f"~/{self.name}/local_plan", 1)
        self._unpublished = False
        self._publish_timer = node.create_timer(1.0 / controller_frequency, self._publish)

    # -- run-time changes (move_base's live parameters) ---------------------------------------------
    def reconfigure(self, config: MppiConfig) -> None:
        self.controller.reconfigure(config)

    def set_controller_frequency(self, controller_frequency: float) -> None:
        self.controller.set_controller_period(1.0 / controller_frequency)
        self._publish_timer.timer_period_ns = round(1e9 / controller_frequency)
        self._publish_timer.reset()

    def set_costmap_footprint(self, footprint) -> None:
        self.controller.set_costmap_footprint(footprint)

    # -- odometry -------------------------------------------------------------------------------------
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

    # -- the controller interface of move_base -------------------------------------------------------
    def set_plan(self, plan: np.ndarray) -> bool:
        in_frame = self._in_local_frame(plan)
        if in_frame is None:
            return False
        self._plan = plan
        self.controller.set_plan(in_frame)
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
        """The cycle's robot pose; the plan follows the latest map -> odom, once."""
        self._pose = pose
        if self.plan_frame != self.frame and self._plan is not None:
            in_frame = self._in_local_frame(self._plan)
            if in_frame is not None:
                self.controller.move_plan(in_frame)

    def reset(self) -> None:
        self.controller.reset()

    def compute(self) -> ControlResult:
        pose = self._pose
        if pose is None:
            return ControlResult(False, message=f"no robot pose: {self.costmap_ros.last_pose_error}")
        moving = self.obstacle_feed.moving_obstacles(self._now(), self.frame)
        self.controller.set_dynamic_obstacles(moving.rows, moving.covariance)
        with self.costmap_ros.lock:
            result = self.controller.compute_velocity_commands(pose[:3], self._robot_velocity(),
                                                               self.costmap_ros.costmap)
        self._unpublished = True
        log_notices(self.logger, self.controller.pop_notices())
        return ControlResult(result.ok, result.v, result.omega, result.message)

    def is_goal_reached(self) -> bool:
        pose = self._pose
        return pose is not None and self.controller.is_goal_reached(pose[:3], self._robot_velocity())

    # -- visualisation --------------------------------------------------------------------------------
    def _publish(self) -> None:
        if not self._unpublished:
            return
        self._unpublished = False
        if self.local_plan_pub.get_subscription_count():
            self.local_plan_pub.publish(path_msg(self.controller.trajectory, self.frame,
                                                 self.node.get_clock().now().to_msg()))
