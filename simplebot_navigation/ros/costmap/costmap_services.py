"""Nav2's costmap services on a Costmap2DROS: clear it entirely, around the robot or a pose, or all but a
region around the robot, and get a copy of it (docs/design.md §7)."""

from __future__ import annotations

import math

import numpy as np
from nav2_msgs.msg import Costmap
from nav2_msgs.srv import (ClearCostmapAroundPose, ClearCostmapAroundRobot, ClearCostmapExceptRegion,
                           ClearEntireCostmap, GetCostmap)

from simplebot_navigation.ros.conversions import pose_to_xyyaw, xyyaw_to_pose
from simplebot_navigation.ros.poses import in_frame, validate_pose
from simplebot_navigation.ros.qos import SERVICE_QOS

#: the side (m) of a square to clear is at most this
MAX_RESET_DISTANCE_M = 1000.0


def _reset_distance(value: float) -> str | None:
    if not (math.isfinite(value) and 0.0 < value <= MAX_RESET_DISTANCE_M):
        return f"reset_distance must be in (0, {MAX_RESET_DISTANCE_M:g}] m, got {value:g}"
    return None


class CostmapServices:
    """The services of the costmap ``name`` (global_costmap or local_costmap) under ``name``/ in the node's
    namespace, as Nav2's costmap node serves them. The clearing ones clear the obstacle layers (Nav2's clearable
    layers); clear_entirely resets every layer."""

    def __init__(self, node, costmap_ros, name: str):
        self.node, self.costmap_ros, self.name = node, costmap_ros, name
        for srv_type, service, callback in (
                (ClearEntireCostmap, f"clear_entirely_{name}", self._clear_entirely),
                (ClearCostmapExceptRegion, "clear_costmap_except_region", self._clear_except),
                (ClearCostmapAroundRobot, "clear_costmap_around_robot", self._clear_around_robot),
                (ClearCostmapAroundPose, "clear_costmap_around_pose", self._clear_around_pose),
                (GetCostmap, "get_costmap", self._get_costmap)):
            node.create_service(srv_type, f"{name}/{service}", callback, qos_profile=SERVICE_QOS)

    def _refuse(self, service: str, reason: str) -> None:
        self.node.get_logger().error(f"{self.name}/{service}: {reason}")

    def _clear_entirely(self, _request, response):
        self.costmap_ros.reset_layers()
        self.node.get_logger().info(f"{self.name}: cleared entirely")
        return response

    def _clear_square(self, service: str, xy, reset_distance: float, inside: bool) -> None:
        reason = _reset_distance(reset_distance)
        if reason is None and xy is None:
            reason = f"no robot pose in {self.costmap_ros.global_frame}: {self.costmap_ros.last_pose_error}"
        if reason is not None:
            self._refuse(service, reason)
            return
        cleared = self.costmap_ros.clear_layers_outside(xy[0], xy[1], reset_distance, None, inside)
        self.node.get_logger().info(f"{self.name}/{service}: cleared {'inside' if inside else 'outside'} the "
                                    f"{reset_distance:g} m square at ({xy[0]:.2f}, {xy[1]:.2f}) in "
                                    f"{', '.join(cleared) or 'no layer'}")

    def _robot_xy(self):
        pose = self.costmap_ros.get_robot_pose()
        return None if pose is None else (pose[0], pose[1])

    def _clear_except(self, request, response):
        self._clear_square("clear_costmap_except_region", self._robot_xy(), request.reset_distance, False)
        return response

    def _clear_around_robot(self, request, response):
        self._clear_square("clear_costmap_around_robot", self._robot_xy(), request.reset_distance, True)
        return response

    def _clear_around_pose(self, request, response):
        reason = validate_pose(request.pose, "pose")
        target = None
        if reason is None:
            target, reason = in_frame(request.pose, self.costmap_ros.global_frame, self.costmap_ros.tf, "pose")
        if reason is not None:
            self._refuse("clear_costmap_around_pose", reason)
            return response
        self._clear_square("clear_costmap_around_pose", pose_to_xyyaw(target.pose)[:2], request.reset_distance, True)
        return response

    def _get_costmap(self, _request, response):
        with self.costmap_ros.lock:
            master = self.costmap_ros.costmap
            msg = Costmap()
            msg.metadata.resolution = float(master.resolution)
            msg.metadata.size_x, msg.metadata.size_y = int(master.size_x), int(master.size_y)
            msg.metadata.origin = xyyaw_to_pose(master.origin_x, master.origin_y, 0.0)
            msg.data = np.ascontiguousarray(master.costmap, dtype=np.uint8).ravel().tobytes()
        stamp = self.node.get_clock().now().to_msg()
        msg.header.frame_id = self.costmap_ros.global_frame
        msg.header.stamp = msg.metadata.update_time = stamp
        msg.metadata.layer = "master"
        response.map = msg
        return response
