"""move_base's moving-obstacle tracking: the ROS shell around perception's ObstacleTracker (docs/reference.md §6).

Every LaserScan the local costmap takes in (its shared subscription and message filter, so no second copy and
no second wait for TF) also goes to the tracker, in the local costmap's global frame at the scan's stamp. After
each scan the moving tracks go out on the local planner's obstacles topic and, to whoever watches, as markers;
before each update both costmaps get the circles where moving tracks are and just were, to clear their marks.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from costmap_converter_msgs.msg import ObstacleArrayMsg
from rclpy.node import Node
from rclpy.time import Time
from visualization_msgs.msg import MarkerArray

from simplebot_navigation.costmap.obstacle_layer import scan_problem
from simplebot_navigation.geometry import quaternion_to_rotation_matrix, transform_points
from simplebot_navigation.move_base.parameter_tree import OBSTACLE_TRACKING
from simplebot_navigation.parameters import fields_of
from simplebot_navigation.perception import ObstacleTracker, Scan, TrackerParams
from simplebot_navigation.ros.conversions import transform_to_xyyaw
from simplebot_navigation.ros.costmap.costmap_input import stamp_seconds
from simplebot_navigation.ros.costmap.costmap_log import Throttle
from simplebot_navigation.ros.move_base.obstacle_msgs import obstacle_array_msg, track_markers
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.tf import TransformException

#: own publications remembered, to tell them from other nodes' on the same topic
OWN_MESSAGES_KEPT = 20
WARNING_PERIOD_S = 5.0


class ObstacleTracking:
    """Owned by the move_base node: ``ObstacleTracking(node, local_costmap, global_costmap, tf, obstacles_topic)``.
    The local planner reads ``moving_obstacles(now)`` and ``params.external_timeout``, and skips messages for
    which ``is_own(msg)`` holds."""

    def __init__(self, node: Node, local_costmap, global_costmap, tf_buffer, obstacles_topic: str):
        self.node = node
        self.logger = node.get_logger()
        self.tf = tf_buffer
        self.frame = local_costmap.global_frame
        self.params = TrackerParams.from_params(given_parameter_tree(node, OBSTACLE_TRACKING),
                                                f"move_base/{OBSTACLE_TRACKING}")
        for warning in self.params.warnings:
            self.logger.warn(warning)
        declare_defaults(node, {name: getattr(self.params, name) for name in fields_of(TrackerParams)},
                         prefix=OBSTACLE_TRACKING, specs=fields_of(TrackerParams))
        self.tracker = ObstacleTracker(self.params)
        self.throttle = Throttle()
        self._own: deque = deque(maxlen=OWN_MESSAGES_KEPT)
        self.obstacles_pub = create_publisher(node, ObstacleArrayMsg, obstacles_topic, 10)
        self.markers_pub = create_publisher(node, MarkerArray, "~/obstacle_tracks/markers", 1)
        local_costmap.input.scan_listeners.append(self._on_scan)
        for costmap in (local_costmap, global_costmap):
            costmap.clearing_source = lambda costmap=costmap: self.clearing_circles(costmap.global_frame)

    # -- parameters and time ---------------------------------------------------------------------
    def reconfigure(self, params: TrackerParams) -> None:
        """New obstacle_tracking parameters (already checked); switched off, every track is forgotten."""
        was_enabled, self.params = self.params.enabled, params
        self.tracker.reconfigure(params)
        if was_enabled and not params.enabled:
            self.reset()
            self._publish(self.node.get_clock().now().to_msg())

    def reset(self) -> None:
        """Time jumped back, or tracking was switched off: the tracks belong to the past."""
        self.tracker.reset()

    def _now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def _warn(self, key: str, text: str) -> None:
        if self.throttle(key, WARNING_PERIOD_S):
            self.logger.warning(text)

    # -- scans in, obstacles out -------------------------------------------------------------------
    def _on_scan(self, source, msg, tf) -> None:
        """A scan the local costmap took, with its sensor -> global transform at the scan's stamp."""
        if not self.params.enabled:
            return
        t, q = tf.transform.translation, tf.transform.rotation
        ranges = np.asarray(msg.ranges, dtype=float)
        problem = scan_problem(ranges, msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max,
                               np.array([t.x, t.y, t.z, q.x, q.y, q.z, q.w]))
        if problem:
            self._warn(("scan", source.topic, problem[0]), f"obstacle tracking: scan on {source.topic} skipped: "
                       f"{problem[1]}")
            return
        rotation = quaternion_to_rotation_matrix(q.x, q.y, q.z, q.w)
        beams = msg.angle_min + msg.angle_increment * np.arange(len(ranges))
        # A tilted or upside-down sensor still scans a plane: the beams' bearings in the global frame.
        directions = rotation[:2, :2] @ np.stack([np.cos(beams), np.sin(beams)])
        angles = np.unwrap(np.arctan2(directions[1], directions[0]))
        scan = Scan(np.array([t.x, t.y]), angles, ranges, float(msg.range_min), float(msg.range_max))
        if self.tracker.update([scan], stamp_seconds(Time.from_msg(msg.header.stamp))):
            self._publish(msg.header.stamp)

    def _publish(self, stamp) -> None:
        moving = [track for track in self.tracker.tracks() if track.moving]
        msg = obstacle_array_msg(moving, self.frame, stamp)
        self._own.append(_key(msg))
        self.obstacles_pub.publish(msg)
        if self.markers_pub.get_subscription_count():
            self.markers_pub.publish(track_markers(self.tracker.tracks(), self.frame, stamp))

    def is_own(self, key: tuple) -> bool:
        """Whether this node published the message of ``key`` (ObstacleArray.key: stamp, frame, obstacle ids).
        rclpy 7.1's message info carries no publisher gid, so own messages are known by these."""
        return key in self._own

    # -- what the costmaps and the local planner read --------------------------------------------
    def moving_obstacles(self, now: float) -> np.ndarray:
        """Rows [x, y, vx, vy, radius] in the local costmap's global frame, positions at `now`."""
        if not self.params.enabled:
            return np.empty((0, 5))
        return self.tracker.moving_obstacles(now)

    def clearing_circles(self, frame: str) -> np.ndarray:
        """The tracker's clearing circles at the node's time, in `frame` (empty when TF cannot say where)."""
        if not self.params.enabled:
            return np.empty((0, 3))
        circles = self.tracker.clearing_circles(self._now())
        if frame == self.frame or not len(circles):
            return circles
        try:
            tf = self.tf.lookup_transform(frame, self.frame, Time())
        except TransformException as err:
            self._warn(("clearing tf", frame), f"obstacle tracking: no moving-obstacle clearing in {frame}: {err}")
            return np.empty((0, 3))
        return np.column_stack([transform_points(transform_to_xyyaw(tf), circles[:, :2]), circles[:, 2]])


def _key(msg: ObstacleArrayMsg) -> tuple:
    stamp = msg.header.stamp
    return stamp.sec, stamp.nanosec, msg.header.frame_id, tuple(obstacle.id for obstacle in msg.obstacles)


__all__ = ["ObstacleTracking"]
