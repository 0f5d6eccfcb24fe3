"""What every local planner's ROS shell does alike: the global plan moved into the local costmap's frame, the
cycle's robot pose (begin_cycle), odometry, move_base's moving obstacles, the costmap's lock, live changes, and a
timer of its own for what it publishes.

A pure planner (TebLocalPlanner, MppiController) answers set_plan, move_plan, reset, set_dynamic_obstacles,
compute_velocity_commands, is_goal_reached, pop_notices, reconfigure, set_controller_period and
set_costmap_footprint; a shell subclasses LocalPlannerShell with it as ``planner`` and publishes in ``_publish``.
"""

from __future__ import annotations

import math

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time

from simplebot_navigation.geometry import transform_points
from simplebot_navigation.move_base.plugins import ControlResult, plugin_namespace
from simplebot_navigation.ros.conversions import transform_to_xyyaw
from simplebot_navigation.ros.tf import Buffer, TransformException

#: odometry older than this (node time) is not the robot's velocity any more
ODOM_STALE_S = 1.0


class LocalPlannerShell:
    """move_base's LocalPlannerPlugin (move_base/plugins.py) around a pure ``planner`` of ``config``, whose
    ``odom_topic`` it subscribes."""

    def __init__(self, node: Node, plugin_type: str, costmap_ros, tf_buffer: Buffer, controller_frequency: float,
                 plan_frame: str, obstacle_feed, config, planner):
        self.node, self.name, self.costmap_ros, self.tf = node, plugin_namespace(plugin_type), costmap_ros, tf_buffer
        self.plan_frame, self.obstacle_feed = plan_frame, obstacle_feed
        self.config, self.planner = config, planner
        self.logger = node.get_logger()
        self.frame = costmap_ros.global_frame
        self._plan: np.ndarray | None = None    # the latest global plan, in plan_frame
        self._pose = None                       # the robot pose of this control cycle (begin_cycle)
        self.odom_topic = config.odom_topic
        self._velocity = (0.0, 0.0)
        self._odom_time: float | None = None  # node clock (sim time), so lockstep runs do not depend on wall speed
        node.create_subscription(Odometry, self.odom_topic, self._on_odom, 10)
        self._unpublished = False
        self._publish_timer = node.create_timer(1.0 / controller_frequency, self._publish)

    # -- run-time changes (move_base's live parameters) ---------------------------------------------
    def reconfigure(self, config) -> None:
        """New values of the namespace, used from the next control cycle."""
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
        """What the latest control cycle planned, to the topics someone listens to (the timer's callback)."""
        raise NotImplementedError


def log_notices(logger, notices) -> None:
    """The planner's (level, message) notices, one call site per severity: rclpy raises when the
    severity of a call site changes between calls."""
    for level, notice in notices:
        if level == "warn":
            logger.warn(notice)
        else:
            logger.info(notice)
