"""Obstacles other nodes publish on the local planner's obstacles topic, as teb_local_planner takes custom
obstacles (docs/reference.md §6).

The latest message replaces the previous one and is used for external_timeout after it arrived. Its obstacles are
converted into the planning frame through TF at the message's stamp (the latest transform if that is not
available): positions transformed, velocities rotated. Bad obstacles are dropped with a warning naming the field.

Any node may publish here, so the subscription takes the serialized bytes: a message beyond the caps of
obstacle_msgs.py (100,000 obstacles, a polygon of 10,000 points) is refused whole after reading its lengths,
before a Python object is built per obstacle or point, and at most OBSTACLE_QUEUE messages wait in the middleware.
"""

from __future__ import annotations

import numpy as np
from costmap_converter_msgs.msg import ObstacleArrayMsg
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.time import Time

from simplebot_navigation.geometry import transform_points
from simplebot_navigation.perception.feed import MovingObstacles
from simplebot_navigation.ros.conversions import transform_to_xyyaw
from simplebot_navigation.log_throttle import Throttle
from simplebot_navigation.ros.move_base.obstacle_msgs import RefusedMessage, read_obstacle_array
from simplebot_navigation.ros.tf import ExtrapolationException, TransformException, strip_frame

WARNING_PERIOD_S = 5.0
#: messages the middleware keeps for the subscription: only the latest counts, but two publishers must not push
#: each other's out while a control cycle runs; the middleware keeps this many samples of the largest size seen
OBSTACLE_QUEUE = 5


class ExternalObstacles:
    """An ObstacleSource (perception/feed.py): the latest message's obstacles in `frame`, for `timeout` seconds
    after it arrived. Their covariance is taken as zero (the message's twist covariance is not read)."""

    def __init__(self, node: Node, topic: str, frame: str, tf_buffer, timeout: float):
        self.node = node
        self.topic = topic
        self.frame = frame
        self.tf = tf_buffer
        self.timeout = timeout
        self.throttle = Throttle()
        self._rows = np.empty((0, 5))
        self._stamp = 0.0
        self._arrival: float | None = None
        self.subscription = node.create_subscription(ObstacleArrayMsg, topic, self._on_message,
                                                     QoSProfile(depth=OBSTACLE_QUEUE), raw=True)

    def _now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def _warn(self, key, text: str) -> None:
        if self.throttle(key, WARNING_PERIOD_S):
            self.node.get_logger().warning(f"obstacles on {self.topic}: {text}")

    def _on_message(self, raw: bytes) -> None:
        try:
            msg = read_obstacle_array(raw)
        except RefusedMessage as refused:
            self._warn(("message", refused.field), f"message of {len(raw)} bytes refused: {refused}")
            return
        for field, problem in msg.problems:
            self._warn(("obstacle", field), f"obstacle dropped: {problem}")
        frame = strip_frame(msg.frame)
        now = self._now()
        stamp = msg.sec + msg.nanosec * 1e-9
        stamp = stamp if 0.0 < stamp <= now else now       # unset or future stamps: positions as of now
        rows = msg.rows
        if len(rows) and frame != self.frame:
            rows = self._in_planning_frame(rows, frame, stamp)
            if rows is None:
                return
        self._rows, self._stamp, self._arrival = rows, stamp, now

    def _in_planning_frame(self, rows: np.ndarray, frame: str, stamp: float) -> np.ndarray | None:
        if not frame:
            self._warn("frame", "message dropped: header.frame_id is empty")
            return None
        try:
            try:
                tf = self.tf.lookup_transform(self.frame, frame, Time(nanoseconds=round(stamp * 1e9)))
            except ExtrapolationException:
                tf = self.tf.lookup_transform(self.frame, frame, Time())
        except (TransformException, ValueError) as err:
            self._warn(("frame", frame), f"message dropped: header.frame_id '{frame}' cannot be transformed to "
                       f"{self.frame}: {err}")
            return None
        x, y, yaw = transform_to_xyyaw(tf)
        out = rows.copy()
        out[:, :2] = transform_points((x, y, yaw), rows[:, :2])
        out[:, 2:4] = transform_points((0.0, 0.0, yaw), rows[:, 2:4])
        return out

    def moving_obstacles(self, now: float) -> MovingObstacles:
        """The last message's obstacles at `now`, or none once it is older than timeout (or from the future:
        time jumped back)."""
        if self._arrival is None or not 0.0 <= now - self._arrival <= self.timeout:
            return MovingObstacles.empty(self.frame, now)
        out = self._rows.copy()
        out[:, :2] += (now - self._stamp) * out[:, 2:4]
        return MovingObstacles(self.frame, now, out, np.zeros((len(out), 4, 4)))

    def clearing_circles(self, now: float) -> np.ndarray:
        """None: another node's obstacles leave the costmaps as they are (teb_local_planner's custom obstacles)."""
        return np.empty((0, 3))
