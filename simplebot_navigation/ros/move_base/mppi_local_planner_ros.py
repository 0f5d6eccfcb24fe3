"""MPPILocalPlannerROS: the ROS shell move_base owns around the pure MppiController (docs/reference.md §4.10).

A LocalPlannerShell (the plan in the local frame, odometry, the moving obstacles of move_base's obstacle feed, the
costmap's lock) that publishes the trajectory the command starts as ``~/MPPILocalPlannerROS/local_plan``, from its
own timer and only while someone subscribes.
"""

from __future__ import annotations

from nav_msgs.msg import Path
from rclpy.node import Node

from simplebot_navigation.move_base.plugins import plugin_namespace
from simplebot_navigation.mppi import MppiConfig, MppiController, warm_up
from simplebot_navigation.parameters import fields_of, values_of
from simplebot_navigation.ros.conversions import path_msg
from simplebot_navigation.ros.move_base.local_planner_shell import LocalPlannerShell
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.tf import Buffer


class MPPILocalPlannerROS(LocalPlannerShell):
    """move_base's LocalPlannerPlugin (move_base/plugins.py) around the pure MppiController."""

    def __init__(self, node: Node, plugin_type: str, costmap_ros, tf_buffer: Buffer, controller_frequency: float,
                 plan_frame: str, obstacle_feed):
        name = plugin_namespace(plugin_type)
        config = MppiConfig.from_params(given_parameter_tree(node, name))
        for warning in config.warnings:
            node.get_logger().warn(warning)
        controller = MppiController(config, costmap_ros.footprint, 1.0 / controller_frequency)
        warm_up()  # compiled kernels loaded now, not in the first control cycle of the first goal
        declare_defaults(node, values_of(config), name, specs=fields_of(MppiConfig))
        self.local_plan_pub = create_publisher(node, Path, f"~/{name}/local_plan", 1)
        super().__init__(node, plugin_type, costmap_ros, tf_buffer, controller_frequency, plan_frame, obstacle_feed,
                         config, controller)

    # -- visualisation --------------------------------------------------------------------------------
    def _publish(self) -> None:
        if not self._unpublished:
            return
        self._unpublished = False
        if self.local_plan_pub.get_subscription_count():
            self.local_plan_pub.publish(path_msg(self.planner.trajectory, self.frame,
                                                 self.node.get_clock().now().to_msg()))
