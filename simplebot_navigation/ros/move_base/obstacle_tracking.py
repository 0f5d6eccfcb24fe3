"""move_base's moving-obstacle tracking: the ROS shell around perception's ObstacleTracker, one source of the obstacle
feed (perception/feed.py, docs/reference.md §6).

Every LaserScan the local costmap takes in (its shared subscription and message filter, so no second copy and
no second wait for TF) also comes here, in the local costmap's global frame at the scan's stamp: the local costmap
is built with ``scan_observer=tracking.on_scan``. After each scan the tracks go out on ``~/obstacle_tracks`` and,
to whoever watches, as markers; the costmaps and the local planner read them through the feed.
"""

from __future__ import annotations

import numpy as np
from costmap_converter_msgs.msg import ObstacleArrayMsg
from nav_msgs.msg import OccupancyGrid
from rclpy.node import Node
from rclpy.time import Time
from visualization_msgs.msg import MarkerArray

from simplebot_navigation.laser_scan import scan_problem
from simplebot_navigation.geometry import compose2, inverse2, quaternion_to_rotation_matrix, transform_points
from simplebot_navigation.move_base.parameter_tree import OBSTACLE_TRACKING
from simplebot_navigation.parameters import fields_of
from simplebot_navigation.perception import ObstacleTracker, Scan, TrackerParams, tracking_kernels
from simplebot_navigation.perception.feed import MovingObstacles
from simplebot_navigation.perception.structure import StaticCells
from simplebot_navigation.ros.conversions import checked_occupancy_map, stamp_seconds, transform_to_xyyaw
from simplebot_navigation.log_throttle import Throttle
from simplebot_navigation.ros.move_base.obstacle_msgs import obstacle_array_msg, track_markers
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.ros.tf import TransformException, strip_frame

WARNING_PERIOD_S = 5.0
#: a map cell at or above this occupancy (map_server's occupied_thresh, 0.65) is static
MAP_OCCUPIED = 65
#: the topic of the tracks, under move_base's name
TRACKS_TOPIC = "~/obstacle_tracks"


class ObstacleTracking:
    """An ObstacleSource (perception/feed.py) owned by the move_base node; its frame is the one the local
    costmap's scans arrive in, known from the first scan on."""

    def __init__(self, node: Node, tf_buffer):
        self.node = node
        self.logger = node.get_logger()
        self.frame = ""
        self.params = TrackerParams.from_params(given_parameter_tree(node, OBSTACLE_TRACKING),
                                                f"move_base/{OBSTACLE_TRACKING}")
        for warning in self.params.warnings:
            self.logger.warn(warning)
        declare_defaults(node, {name: getattr(self.params, name) for name in fields_of(TrackerParams)},
                         prefix=OBSTACLE_TRACKING, specs=fields_of(TrackerParams))
        self.tracker = ObstacleTracker(self.params)
        tracking_kernels.warm_up()     # loaded now, not at the first scan
        self.throttle = Throttle()
        self.tracks_pub = create_publisher(node, ObstacleArrayMsg, TRACKS_TOPIC, 10)
        self.robot_tracks_pub = create_publisher(node, ObstacleArrayMsg, f"{TRACKS_TOPIC}/robot_frame", 10)
        #: the robot's frame, for the tracks in it (the collision monitor's; move_base sets it from its costmap)
        self.robot_frame = ""
        self.markers_pub = create_publisher(node, MarkerArray, f"{TRACKS_TOPIC}/markers", 1)
        self.tf = tf_buffer
        if self.params.static_map_topic:
            node.create_subscription(OccupancyGrid, self.params.static_map_topic, self._on_map, LATCHED)

    # -- what a map knows to be static -----------------------------------------------------------
    def _on_map(self, msg: OccupancyGrid) -> None:
        """The map's occupied cells are static: the tracker is told so (a map that cannot be used changes nothing)."""
        try:
            grid = checked_occupancy_map(msg, "obstacle tracking")
        except ValueError as err:
            self._warn(("map",), f"obstacle tracking: map on {self.params.static_map_topic} ignored: {err}")
            return
        cells = StaticCells(grid.data >= MAP_OCCUPIED, grid.resolution, (0.0, 0.0))
        frame = strip_frame(msg.header.frame_id) or "map"
        self.tracker.set_static_cells(lambda points: self._on_map_cells(points, frame, grid.origin, cells))

    def _on_map_cells(self, points: np.ndarray, map_frame: str, origin, cells: StaticCells) -> np.ndarray:
        """Which of `points` (tracking frame) lie on the map's occupied cells, placed by the latest TF."""
        try:
            in_map = transform_to_xyyaw(self.tf.lookup_transform(map_frame, self.frame, Time()))
        except TransformException as err:
            self._warn(("map tf",), f"obstacle tracking: the map's static cells are not used while {map_frame} <- "
                       f"{self.frame} is unknown: {err}")
            return np.zeros(len(points), dtype=bool)
        return cells(transform_points(compose2(inverse2(origin), in_map), points))

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

    def _warn(self, key: str, text: str) -> None:
        if self.throttle(key, WARNING_PERIOD_S):
            self.logger.warning(text)

    # -- scans in, obstacles out -------------------------------------------------------------------
    def on_scan(self, source, msg, tf) -> None:
        """A scan the local costmap took, with its sensor -> global transform at the scan's stamp."""
        if not self.params.enabled:
            return
        frame = strip_frame(tf.header.frame_id)
        if frame != self.frame:
            if self.frame:
                self._warn(("frame", frame), f"obstacle tracking: scans now arrive in {frame}, not {self.frame}: "
                           "tracks forgotten")
            self.tracker.reset()
            self.frame = frame
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
        """The moving tracks, as the feed gives them (the markers show the others too)."""
        moving = [track for track in self.tracker.tracks() if track.moving]
        self.tracks_pub.publish(obstacle_array_msg(moving, self.frame, stamp))
        if self.robot_frame and self.robot_tracks_pub.get_subscription_count():
            try:       # the scan was just placed at its stamp: so is the robot
                robot = transform_to_xyyaw(self.tf.lookup_transform(self.robot_frame, self.frame, Time.from_msg(stamp)))
            except TransformException as err:
                self._warn(("robot frame",), f"obstacle tracking: tracks not published in {self.robot_frame}: {err}")
            else:
                self.robot_tracks_pub.publish(obstacle_array_msg(moving, self.robot_frame, stamp, robot))
        if self.markers_pub.get_subscription_count():
            self.markers_pub.publish(track_markers(self.tracker.tracks(), self.frame, stamp))

    # -- the ObstacleSource ------------------------------------------------------------------------
    def moving_obstacles(self, now: float) -> MovingObstacles:
        """The moving tracks in the local costmap's global frame, positions and covariances at `now`."""
        if not self.params.enabled:
            return MovingObstacles.empty(self.frame, now)
        return MovingObstacles(self.frame, now, self.tracker.moving_obstacles(now),
                               self.tracker.moving_covariances(now))

    def clearing_circles(self, now: float) -> np.ndarray:
        """Where moving tracks are and just were, at `now`, in the same frame."""
        if not self.params.enabled:
            return np.empty((0, 3))
        return self.tracker.clearing_circles(now)


__all__ = ["ObstacleTracking"]
