"""GlobalPlannerROS: the ROS shell of the global planner, owned by move_base (docs/reference.md §3.1).

Selected by ``base_global_planner`` (global_planner/GlobalPlanner or navfn/NavfnROS). It reads
the ``<name>.*`` parameters of its node, plans on the global costmap's master grid while holding
the costmap's lock, and offers ROS 1's planner interfaces under the node's private namespace:
``~<name>/plan`` (nav_msgs/Path, every plan, empty on failure), ``~<name>/potential``
(nav_msgs/OccupancyGrid, when publish_potential) and the ``~<name>/make_plan`` service
(nav_msgs/GetPlan, read as move_base's make_plan reads it: ros/move_base/move_base_goal.py plan_request).

The costmap is duck-typed, so the planner does not depend on how the costmap is kept: it needs
``costmap`` (Costmap2D), ``lock``, ``global_frame``, ``tf`` (the transform buffer, for requests in
other frames) and ``get_robot_pose()`` -> (x, y, yaw, stamp) or None.
"""

from __future__ import annotations

import math
import time

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from nav_msgs.msg import OccupancyGrid, Path
from nav_msgs.srv import GetPlan
from rclpy.node import Node

from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.move_base.plugins import plugin_namespace
from simplebot_navigation.planning import (GlobalPlanner, GlobalPlannerConfig, PlanFailure, PlanResult,
                                           make_global_planner, potential_to_occupancy, warm_up)
from simplebot_navigation.planning.config import parameter_specs, resolved_parameters
from simplebot_navigation.ros.conversions import occupancy_grid_msg, path_msg
from simplebot_navigation.ros.move_base.move_base_goal import plan_request
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.qos import SERVICE_QOS
from simplebot_navigation.ros.tf import strip_frame

#: ROS 1 warns about a start or goal off the costmap at most once a second
OFF_MAP_WARNING_PERIOD_S = 1.0
_OFF_MAP = (PlanFailure.START_OFF_MAP, PlanFailure.GOAL_OFF_MAP)


def potential_grid_msg(potential: np.ndarray, publish_scale: int, resolution: float, origin_x: float,
                       origin_y: float, frame_id: str, stamp: TimeMsg) -> OccupancyGrid:
    """The ``potential`` OccupancyGrid: the costmap's geometry, potential scaled to 0..publish_scale."""
    msg = occupancy_grid_msg(np.zeros(potential.shape, np.uint8), resolution, origin_x, origin_y,
                             frame_id, stamp)
    msg.data = potential_to_occupancy(potential, publish_scale).ravel().tobytes()
    return msg


class GlobalPlannerROS:
    """``GlobalPlannerROS(node, 'global_planner/GlobalPlanner', global_costmap_ros)``."""

    def __init__(self, node: Node, plugin_type: str, costmap_ros, callback_group=None):
        self.name = plugin_namespace(plugin_type)    # parameter namespace and topic prefix
        self.node = node
        self.costmap_ros = costmap_ros
        self.logger = node.get_logger()
        self.planner = make_global_planner(plugin_type, given_parameter_tree(node, self.name))
        self.config = self.planner.config
        for warning in self.config.warnings:
            self.logger.warning(warning)
        declare_defaults(node, resolved_parameters(self.config), prefix=self.name,
                         specs=parameter_specs(self.config))
        warm_up()
        self._last_off_map_warning: dict[PlanFailure, float] = {}

        self.plan_pub = create_publisher(node, Path, f"~/{self.name}/plan", 1)
        self.potential_pub = create_publisher(node, OccupancyGrid, f"~/{self.name}/potential", 1)
        self.make_plan_srv = node.create_service(GetPlan, f"~/{self.name}/make_plan", self._on_make_plan,
                                                 callback_group=callback_group, qos_profile=SERVICE_QOS)

    def reconfigure(self, config: GlobalPlannerConfig) -> None:
        """New planner parameters (global_planner's dynamic_reconfigure): the next plan is made with them.
        A planner keeps nothing between plans but its cost tables, which are rebuilt here."""
        self.planner = GlobalPlanner(config)
        self.config = config

    @property
    def global_frame(self) -> str:
        return strip_frame(self.costmap_ros.global_frame)

    def make_plan(self, start, goal, tolerance: float | None = None) -> PlanResult:
        """Plan from ``start`` to ``goal`` ((x, y, yaw) in the global frame) on the global costmap.

        ``tolerance`` None means ``default_tolerance``. Publishes the plan (empty on failure) and,
        with publish_potential, the potential; logs the reason of a failure. Non-finite poses or
        tolerance raise ValueError.
        """
        with self.costmap_ros.lock:
            master: Costmap2D = self.costmap_ros.costmap
            geometry = (master.resolution, master.origin_x, master.origin_y)
            result = self.planner.make_plan(master, start, goal, tolerance)
        stamp = self.node.get_clock().now().to_msg()
        self.plan_pub.publish(path_msg(result.poses, self.global_frame, stamp))
        if self.config.publish_potential and result.potential is not None:
            self.potential_pub.publish(potential_grid_msg(result.potential, self.config.publish_scale,
                                                          *geometry, self.global_frame, stamp))
        if not result.ok:
            self._log_failure(result)
        return result

    def blocked_poses(self, poses: np.ndarray, robot_xy) -> np.ndarray:
        """Which poses of a plan lie on cells the planner would not enter now. The robot's own cells
        do not count: the planner frees the start cell, and an inflated cost under the robot is no
        new obstacle."""
        with self.costmap_ros.lock:
            master: Costmap2D = self.costmap_ros.costmap
            blocked = self.planner.blocked_poses(master, poses)
            blocked &= np.hypot(poses[:, 0] - robot_xy[0], poses[:, 1] - robot_xy[1]) > 2.0 * master.resolution
        return blocked

    def destroy(self) -> None:
        self.node.destroy_service(self.make_plan_srv)
        self.node.destroy_publisher(self.plan_pub)
        self.node.destroy_publisher(self.potential_pub)

    # -- internals ---------------------------------------------------------------------------------
    def _log_failure(self, result: PlanResult) -> None:
        message = f"{self.name}: failed to get a plan: {result.message}"
        if result.failure not in _OFF_MAP:
            # move_base retries every control cycle while it waits for a plan: once a second is enough
            self.logger.error(message, throttle_duration_sec=1.0)
            return
        now = time.monotonic()
        if now - self._last_off_map_warning.get(result.failure, -math.inf) >= OFF_MAP_WARNING_PERIOD_S:
            self._last_off_map_warning[result.failure] = now
            self.logger.warning(message)

    def _on_make_plan(self, request: GetPlan.Request, response: GetPlan.Response) -> GetPlan.Response:
        """A refused request (plan_request says why) gets an empty plan, on ~<name>/plan too."""
        response.plan.header.frame_id = self.global_frame
        response.plan.header.stamp = self.node.get_clock().now().to_msg()
        try:
            start, goal, tolerance = plan_request(request, self.costmap_ros)
        except ValueError as err:
            self.logger.error(f"{self.name}: make_plan request rejected: {err}")
            self.plan_pub.publish(path_msg(np.empty((0, 3)), self.global_frame, response.plan.header.stamp))
            return response
        result = self.make_plan(start, goal, tolerance)
        response.plan = path_msg(result.poses, self.global_frame, response.plan.header.stamp)
        return response
