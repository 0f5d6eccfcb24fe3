"""TebLocalPlannerROS: the ROS shell move_base owns around the pure TebLocalPlanner.

A LocalPlannerShell (the plan in the local frame, odometry, moving obstacles from move_base's obstacle feed,
docs/reference.md §6.3, the costmap's lock) that publishes what the lab visualises (docs/reference.md §4.6). The
visualisation has its own timer, so building markers and paths never delays a velocity command,
and costs nothing while no one subscribes.
"""

from __future__ import annotations

from geometry_msgs.msg import Point, PoseArray
from nav_msgs.msg import Path
from rclpy.node import Node
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.move_base.plugins import plugin_namespace
from simplebot_navigation.parameters import fields_of, values_of
from simplebot_navigation.ros.conversions import path_msg, pose_array_msg
from simplebot_navigation.ros.move_base.local_planner_shell import LocalPlannerShell
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.tf import Buffer
from simplebot_navigation.teb import TebConfig, TebLocalPlanner, warm_up


class TebLocalPlannerROS(LocalPlannerShell):
    """move_base's LocalPlannerPlugin (move_base/plugins.py) around the pure TebLocalPlanner."""

    def __init__(self, node: Node, plugin_type: str, costmap_ros, tf_buffer: Buffer, controller_frequency: float,
                 plan_frame: str, obstacle_feed):
        name = plugin_namespace(plugin_type)
        config = TebConfig.from_params(given_parameter_tree(node, name))
        planner = TebLocalPlanner(config, costmap_ros.footprint, 1.0 / controller_frequency)
        warm_up()  # compiled kernels loaded now, not in the first control cycle of the first goal
        for warning in planner.warnings:
            node.get_logger().warn(warning)
        declare_defaults(node, values_of(config), name, specs=fields_of(TebConfig))
        base = f"~/{name}"
        self.local_plan_pub = create_publisher(node, Path, f"{base}/local_plan", 1)
        self.global_plan_pub = create_publisher(node, Path, f"{base}/global_plan", 1)
        self.poses_pub = create_publisher(node, PoseArray, f"{base}/teb_poses", 1)
        self.markers_pub = create_publisher(node, MarkerArray, f"{base}/teb_markers", 1)
        super().__init__(node, plugin_type, costmap_ros, tf_buffer, controller_frequency, plan_frame, obstacle_feed,
                         config, planner)

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

