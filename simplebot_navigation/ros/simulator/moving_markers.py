"""/sim/moving_obstacles: the moving obstacles' ground truth as a visualization_msgs/MarkerArray.

One CYLINDER or CUBE marker per obstacle (namespace ``moving_obstacles``, id = its index in the world's
``moving:`` list, so the ids are stable), with its height, and an ARROW (namespace ``moving_velocity``)
from its centre along its velocity, one metre per m/s.

The frame is ``map`` when the robots have namespaces (the world origin, with a static map -> robotK/odom
transform). A robot without a namespace has no map frame (docs/design.md §5), so its markers are in
``odom``, placed by the robot's start pose as the map -> odom transform of a namespaced robot is: the
viewer, RViz and Foxglove can then draw them in the lab's fixed frame.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import Point
from rclpy.node import Node
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.geometry import inverse_transform_points, yaw_to_quaternion
from simplebot_navigation.ros.simulator.simulator_robot import MAP_FRAME, set_stamp
from simplebot_navigation.sim.simulator import SimplebotSim
from simplebot_navigation.sim.world import Pose2D

TOPIC = "/sim/moving_obstacles"
#: marker colour (r, g, b, a): orange, apart from the costmaps' and the scans' colours
COLOUR = (1.0, 0.55, 0.0, 0.8)


class MovingObstacleMarkers:
    """Publishes the markers of ``sim``'s moving obstacles; nothing if the world has none."""

    def __init__(self, node: Node, sim: SimplebotSim, namespaced: bool, start: Pose2D):
        self.sim = sim
        self.frame = MAP_FRAME if namespaced else "odom"
        self._origin = (0.0, 0.0, 0.0) if namespaced else (start.x, start.y, start.yaw)
        self.pub = node.create_publisher(MarkerArray, TOPIC, 10) if sim.world.moving else None
        self._msg = MarkerArray()
        for i, obstacle in enumerate(sim.world.moving):
            kind = Marker.CYLINDER if obstacle.shape == "cylinder" else Marker.CUBE
            body = self._marker("moving_obstacles", i, kind)
            sx, sy = (2 * obstacle.radius,) * 2 if obstacle.shape == "cylinder" else obstacle.size
            body.scale.x, body.scale.y, body.scale.z = float(sx), float(sy), obstacle.height
            body.pose.position.z = obstacle.height / 2
            # Boxes are axis-aligned in the world, so turned by the start's yaw in odom.
            body.pose.orientation.z, body.pose.orientation.w = yaw_to_quaternion(-self._origin[2])[2:]
            arrow = self._marker("moving_velocity", i, Marker.ARROW)
            arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.05, 0.1, 0.1
            arrow.points = [Point(z=obstacle.height), Point(z=obstacle.height)]
            self._msg.markers += [body, arrow]

    def _marker(self, ns: str, index: int, kind: int) -> Marker:
        marker = Marker(ns=ns, id=index, type=kind, action=Marker.ADD)
        marker.header.frame_id = self.frame
        marker.color.r, marker.color.g, marker.color.b, marker.color.a = COLOUR
        return marker

    def publish(self) -> None:
        if self.pub is None:
            return
        states = self.sim.moving_obstacle_states()
        places = inverse_transform_points(self._origin, [(s.x, s.y) for s in states]).tolist()
        cos, sin = math.cos(self._origin[2]), math.sin(self._origin[2])
        markers = self._msg.markers
        for (x, y), state, body, arrow in zip(places, states, markers[::2], markers[1::2]):
            set_stamp(body.header.stamp, self.sim.sim_time)
            arrow.header.stamp = body.header.stamp
            body.pose.position.x, body.pose.position.y = x, y
            arrow.points[0].x, arrow.points[0].y = x, y
            arrow.points[1].x = x + cos * state.vx + sin * state.vy
            arrow.points[1].y = y - sin * state.vx + cos * state.vy
        self.pub.publish(self._msg)
