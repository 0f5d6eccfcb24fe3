"""Obstacles other nodes publish on the local planner's obstacles topic, as teb_local_planner takes custom
obstacles (docs/reference.md §6).

The latest message replaces the previous one and is used for external_timeout after it arrived. Its obstacles are
converted into the planning frame through TF at the message's stamp (the latest transform if that is not
available): positions transformed, velocities rotated. Bad obstacles are dropped with a warning naming the field.
"""

from __future__ import annotations

import numpy as np
from costmap_converter_msgs.msg import ObstacleArrayMsg
from rclpy.node import Node
from rclpy.time import Time

from simplebot_navigation.geometry import transform_points
from simplebot_navigation.ros.conversions import transform_to_xyyaw
from simplebot_navigation.ros.costmap.costmap_input import stamp_seconds
from simplebot_navigation.ros.costmap.costmap_log import Throttle
from simplebot_navigation.ros.move_base.obstacle_msgs import obstacle_rows
from simplebot_navigation.ros.tf import ExtrapolationException, TransformException, strip_frame

WARNING_PERIOD_S = 5.0


class ExternalObstacles:
    """``current(now, timeout)``: rows [x, y, vx, vy, radius] in `frame`, positions extrapolated to `now`.
    ``is_own(msg)`` tells the node's own publications, which are skipped."""

    def __init__(self, node: Node, topic: str, frame: str, tf_buffer):
        self.node = node
        self.topic = topic
        self.frame = frame
        self.tf = tf_buffer
        self.is_own = lambda _msg: False
        self.throttle = Throttle()
        self._rows = np.empty((0, 5))
        self._stamp = 0.0
        self._arrival: float | None = None
        self.subscription = node.create_subscription(ObstacleArrayMsg, topic, self._on_message, 10)

    def _now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def _warn(self, key, text: str) -> None:
        if self.throttle(key, WARNING_PERIOD_S):
            self.node.get_logger().warning(f"obstacles on {self.topic}: {text}")

    def _on_message(self, msg: ObstacleArrayMsg) -> None:
        if self.is_own(msg):
            return
        rows, problems = obstacle_rows(msg)
        for problem in problems:
            self._warn(("obstacle", problem.split(":")[1]), f"obstacle dropped: {problem}")
        frame = strip_frame(msg.header.frame_id)
        now = self._now()
        stamp = stamp_seconds(Time.from_msg(msg.header.stamp)) if msg.header.stamp.sec >= 0 else 0.0
        stamp = stamp if 0.0 < stamp <= now else now       # unset or future stamps: positions as of now
        if len(rows) and frame != self.frame:
            rows = self._in_planning_frame(rows, frame, msg.header.stamp)
            if rows is None:
                return
        self._rows, self._stamp, self._arrival = rows, stamp, now

    def _in_planning_frame(self, rows: np.ndarray, frame: str, stamp) -> np.ndarray | None:
        if not frame:
            self._warn("frame", "message dropped: header.frame_id is empty")
            return None
        try:
            try:
                tf = self.tf.lookup_transform(self.frame, frame, Time.from_msg(stamp))
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

    def current(self, now: float, timeout: float) -> np.ndarray:
        """The last message's obstacles at `now`, or none once it is older than timeout (or from the future:
        time jumped back)."""
        if self._arrival is None or not 0.0 <= now - self._arrival <= timeout:
            return np.empty((0, 5))
        out = self._rows.copy()
        out[:, :2] += (now - self._stamp) * out[:, 2:4]
        return out
