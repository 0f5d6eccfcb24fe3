"""slam: slam.Mapper behind slam_toolbox's topics, frames and services (docs/reference.md §13).

In: the scans of every topic in ``scan_topics`` (both lidars; one moment's scans are merged), odometry as TF
(``odom_frame`` -> ``base_frame`` at each scan's stamp; a scan waits up to transform_timeout for it, as behind a
tf2 message filter), ``initialpose``. Out: ``map`` and ``map_metadata``
(latched, every map_update_interval and at once after a loop closure), ``map_frame`` -> ``odom_frame`` on /tf
(post-dated by transform_tolerance after the newest scan, so that it goes stale without scans, as amcl's does),
``~/graph`` (visualization_msgs/MarkerArray). Services: ``~/save_map`` (nav2_msgs/SaveMap: map_server YAML +
image), ``~/serialize_map`` (nav2_msgs/SaveMap, map_url: the session file) and ``~/deserialize_map``
(nav2_msgs/LoadMap).

The mapper runs on a worker thread, as slam_toolbox's asynchronous node does: a scan that comes while it is busy
(a loop closure re-renders the map) is dropped, and map -> odom keeps going out meanwhile. With ``synchronous``
every scan is processed in its callback, in order (lockstep runs).
"""

from __future__ import annotations

import math
import sys
import threading
from collections import deque
from concurrent.futures import ThreadPoolExecutor

from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav2_msgs.srv import LoadMap, SaveMap
from nav_msgs.msg import MapMetaData, OccupancyGrid
from rcl_interfaces.msg import SetParametersResult
from rclpy.qos import qos_profile_sensor_data
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import MarkerArray

from simplebot_navigation.geometry import yaw_to_quaternion
from simplebot_navigation.maps.map_io import save_map
from simplebot_navigation.parameters import ParameterError, fields_of
from simplebot_navigation.ros.amcl.amcl_messages import initial_pose, post_dated
from simplebot_navigation.ros.conversions import occupancy_map_msg, transform_to_xyyaw
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.qos import LATCHED, SERVICE_QOS
from simplebot_navigation.ros.slam.slam_messages import ScanMerger, graph_markers
from simplebot_navigation.ros.tf import (Buffer, TransformBroadcaster, TransformException, TransformListener,
                                         strip_frame)
from simplebot_navigation.slam import session
from simplebot_navigation.slam.mapper import Mapper
from simplebot_navigation.slam.params import SlamParams
from simplebot_navigation.slam.scan_points import scan_points

MAX_SCAN_TOPICS = 8
#: a scan stamped this far ahead of the node's clock is dropped; one this far behind the newest means time went back
MAX_SCAN_AHEAD_S = 1.0
TIME_JUMP_BACK_S = 1.0
#: how long a merged scan waits for its odometry transform (as a tf2 message filter), how often it looks again,
#: and how many merged scans wait at most
RETRY_PERIOD_S = 0.02
MAX_PENDING = 32


class SlamNode(SetUpNode):
    def __init__(self, **kwargs):
        kwargs.setdefault("automatically_declare_parameters_from_overrides", True)
        super().__init__("slam", **kwargs)

    def _set_up(self) -> None:
        self.params = SlamParams.from_params(given_parameter_tree(self))
        for warning in self.params.warnings:
            self.get_logger().warn(warning)
        specs = fields_of(SlamParams)
        declare_defaults(self, {name: getattr(self.params, name) for name in specs}, specs=specs)
        self.topics = self.params.scan_topics.split()
        if not 1 <= len(self.topics) <= MAX_SCAN_TOPICS:
            raise ValueError(f"slam parameter 'scan_topics': 1 to {MAX_SCAN_TOPICS} topics, got {self.topics!r}")
        p = self.params
        self.map_frame, self.odom_frame = strip_frame(p.map_frame), strip_frame(p.odom_frame)
        self.base_frame = strip_frame(p.base_frame)
        self.mapper: Mapper | None = self._first_mapper()
        self._worker = None if p.synchronous else ThreadPoolExecutor(max_workers=1, thread_name_prefix="slam")
        self._busy = threading.Event()
        self._merger = ScanMerger(self.topics)
        self._pending: deque[tuple[int, int, object]] = deque(maxlen=MAX_PENDING)   # (stamp, arrival, points)
        self._odom_error: TransformException | None = None
        self._sensor_poses: dict[str, tuple[float, float, float]] = {}
        self._newest_ns, self._last_used_ns, self._count = -1, -(10 ** 18), 0
        self._map_to_odom: tuple[float, float, float] | None = None
        self._last_map_ns = -(10 ** 18)
        self.tf = Buffer(node=self)
        self._listener = TransformListener(self.tf, self)
        self.tf_broadcaster = TransformBroadcaster(self)
        self.map_pub = create_publisher(self, OccupancyGrid, "map", LATCHED)
        self.metadata_pub = create_publisher(self, MapMetaData, "map_metadata", LATCHED)
        self.graph_pub = create_publisher(self, MarkerArray, "~/graph", LATCHED)
        for topic in self.topics:
            self.create_subscription(LaserScan, topic, lambda msg, t=topic: self._on_scan(t, msg),
                                     qos_profile_sensor_data)
        self.create_subscription(PoseWithCovarianceStamped, "initialpose", self._on_initial_pose, 10)
        self.create_service(SaveMap, "~/save_map", self._on_save_map, qos_profile=SERVICE_QOS)
        self.create_service(SaveMap, "~/serialize_map", self._on_serialize, qos_profile=SERVICE_QOS)
        self.create_service(LoadMap, "~/deserialize_map", self._on_deserialize, qos_profile=SERVICE_QOS)
        if p.transform_publish_period > 0:
            self.create_timer(p.transform_publish_period, self._send_map_to_odom)
        self._retry = self.create_timer(RETRY_PERIOD_S, self._use_pending)
        self._retry.cancel()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        if self.mapper is not None and self.mapper.scans:
            self._publish_map(self.mapper, self.get_clock().now().to_msg())
        self.get_logger().info(f"{p.mode}: scans from {', '.join(self.resolve_topic_name(t) for t in self.topics)}")

    def _first_mapper(self) -> Mapper | None:
        p = self.params
        if not p.map_file_name:
            return Mapper(p) if p.mode == "mapping" else None
        try:
            mapper = session.load(p.map_file_name, p)
        except ValueError as err:
            self.get_logger().error(f"map_file_name: {err}; "
                                    + ("mapping starts afresh" if p.mode == "mapping" else "no map to localize on"))
            return Mapper(p) if p.mode == "mapping" else None
        self.get_logger().info(f"loaded {len(mapper.scans)} nodes from {session.session_path(p.map_file_name)}")
        return mapper

    # -- parameters -----------------------------------------------------------------------------
    def _on_set_parameters(self, params) -> SetParametersResult:
        specs = fields_of(SlamParams)
        fixed = [x.name for x in params if x.name in specs and not specs[x.name].dynamic]
        if fixed:
            return SetParametersResult(successful=False, reason=f"{', '.join(fixed)}: requires restart")
        unknown = [x.name for x in params if x.name not in specs and x.name != "use_sim_time"]
        if unknown:
            return SetParametersResult(successful=False, reason=f"{', '.join(unknown)}: not a parameter of slam")
        values = {name: getattr(self.params, name) for name in specs}
        values.update({x.name: x.value for x in params if x.name in specs})
        try:
            new = SlamParams.from_params(values)
        except (ParameterError, ValueError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        for warning in set(new.warnings) - set(self.params.warnings):
            self.get_logger().warn(warning)
        self.params = new
        if self.mapper is not None:
            self._on_worker(setattr, self.mapper, "params", new)
        return SetParametersResult(successful=True)

    # -- scans ----------------------------------------------------------------------------------
    def _on_scan(self, topic: str, msg: LaserScan) -> None:
        stamp = msg.header.stamp
        stamp_ns, now_ns = stamp.sec * 10 ** 9 + stamp.nanosec, self.get_clock().now().nanoseconds
        if stamp.sec < 0 or stamp_ns > now_ns + MAX_SCAN_AHEAD_S * 1e9:
            why = "negative" if stamp.sec < 0 else (f"{(stamp_ns - now_ns) * 1e-9:.3f} s ahead of the clock (at "
                                                    f"most {MAX_SCAN_AHEAD_S:g} s may be)")
            self.get_logger().warn(f"{topic}: scan dropped: stamp {stamp_ns * 1e-9:.3f} s is {why}",
                                   throttle_duration_sec=5.0)
            return
        if stamp_ns < self._newest_ns - TIME_JUMP_BACK_S * 1e9:
            self._restart_after_time_jump(topic, stamp_ns)
        self._newest_ns = max(self._newest_ns, stamp_ns)
        p = self.params
        try:
            range_min = max(msg.range_min, p.min_laser_range)
            points = scan_points(msg.ranges, msg.angle_min, msg.angle_increment, range_min, msg.range_max,
                                 self._sensor_pose(strip_frame(msg.header.frame_id)), p.max_laser_range)
            if not len(points):
                raise ValueError(f"none of its {len(msg.ranges)} ranges is usable (NaN, -inf or below range_min "
                                 f"{range_min:g} m)")
            ready = self._merger.add(topic, stamp_ns, points)
        except (ValueError, TransformException) as err:
            self.get_logger().warn(f"{topic}: scan dropped: {err}", throttle_duration_sec=5.0)
            return
        for moment_ns, merged in ready:
            self._count += 1
            if self._count % p.throttle_scans == 0:
                self._pending.append((moment_ns, now_ns, merged))
        self._use_pending()

    def _sensor_pose(self, frame: str) -> tuple[float, float, float]:
        if frame not in self._sensor_poses:
            self._sensor_poses[frame] = transform_to_xyyaw(self.tf.lookup_transform(self.base_frame, frame, Time()))
        return self._sensor_poses[frame]

    def _use_pending(self) -> None:
        """The merged scans in order, each once the odometry at its stamp is known; one whose odometry does not come
        within transform_timeout, or cannot come any more (odometry is newer), is dropped with a warning."""
        while self._pending:
            stamp_ns, arrival_ns, points = self._pending[0]
            if not self._use(stamp_ns, points):
                waited = (self.get_clock().now().nanoseconds - arrival_ns) * 1e-9
                if waited <= self.params.transform_timeout and not self._odometry_newer_than(stamp_ns):
                    if self._retry.is_canceled():
                        self._retry.reset()
                    return
                self.get_logger().warn(f"scan dropped: no {self.odom_frame} -> {self.base_frame} transform at its "
                                       f"stamp {stamp_ns * 1e-9:.3f} s (waited {max(waited, 0.0):.2f} s): "
                                       f"{self._odom_error}", throttle_duration_sec=5.0)
            self._pending.popleft()
        self._retry.cancel()

    def _odometry_newer_than(self, stamp_ns: int) -> bool:
        try:
            newest = self.tf.lookup_transform(self.odom_frame, self.base_frame, Time()).header.stamp
        except TransformException:
            return False
        return newest.sec * 10 ** 9 + newest.nanosec > stamp_ns

    def _use(self, stamp_ns: int, points) -> bool:
        """Hand a merged scan to the mapper, unless it is too soon or the mapper is still busy; False while the
        odometry at its stamp is not known."""
        if self.mapper is None:
            self.get_logger().warn("no map to localize on: set map_file_name or call deserialize_map",
                                   throttle_duration_sec=10.0)
            return True
        if stamp_ns - self._last_used_ns < self.params.minimum_time_interval * 1e9:
            return True
        try:
            odom = transform_to_xyyaw(self.tf.lookup_transform(self.odom_frame, self.base_frame, Time(
                nanoseconds=stamp_ns)))
        except TransformException as err:
            self._odom_error = err
            return False
        if self._busy.is_set():
            return True
        self._last_used_ns = stamp_ns
        self._busy.set()
        self._on_worker(self._map_scan, self.mapper, odom, points, stamp_ns)
        return True

    def _on_worker(self, fn, *args):
        """fn(*args) on the mapper's thread, after what is queued there (at once when synchronous); its result."""
        if self._worker is None:
            return _Done(fn(*args))
        return self._worker.submit(fn, *args)

    def _map_scan(self, mapper: Mapper, odom, points, stamp_ns: int) -> None:
        """On the worker: one scan into the mapper, then map -> odom and, when due, the map."""
        try:
            if self._map_to_odom is None and self.params.map_start_pose:
                mapper.set_pose(self.params.map_start_pose, odom)
            update = mapper.add_scan(odom, points)
            self._map_to_odom = mapper.map_to_odom
            self._send_map_to_odom()
            due = stamp_ns - self._last_map_ns >= self.params.map_update_interval * 1e9
            if update.node is not None and (update.closed or due or len(mapper.scans) == 1):
                self._last_map_ns = stamp_ns
                self._publish_map(mapper, Time(nanoseconds=stamp_ns).to_msg())
        except ValueError as err:
            self.get_logger().warn(f"scan dropped: {err}", throttle_duration_sec=5.0)
        except Exception as err:    # noqa: BLE001 -- the node keeps its map whatever one scan does
            self.get_logger().error(f"scan dropped: {type(err).__name__}: {err}", throttle_duration_sec=5.0)
        finally:
            self._busy.clear()

    def _restart_after_time_jump(self, topic: str, stamp_ns: int) -> None:
        self.get_logger().warn(f"{topic}: time went back from {self._newest_ns * 1e-9:.2f} s to {stamp_ns * 1e-9:.2f} "
                               "s: the transform buffer is cleared and the map goes on from the last pose")
        self.tf.clear()
        self._sensor_poses.clear()
        self._merger.clear()
        self._pending.clear()
        self._newest_ns, self._last_used_ns, self._last_map_ns = -1, -(10 ** 18), -(10 ** 18)
        if self.mapper is not None:
            self._on_worker(self.mapper.restart_odometry)

    def _on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        if self.mapper is None:
            self.get_logger().warn("initialpose ignored: no map yet")
            return
        try:
            x, y, yaw, _ = initial_pose(msg)
            odom = transform_to_xyyaw(self.tf.lookup_transform(self.odom_frame, self.base_frame, Time()))
        except (ValueError, TransformException) as err:
            self.get_logger().warn(f"initialpose ignored: {err}")
            return
        self._on_worker(self._set_pose, self.mapper, (x, y, yaw), odom)
        self.get_logger().info(f"initial pose ({x:.3f}, {y:.3f}, {math.degrees(yaw):.1f} deg) in {self.map_frame}")

    def _set_pose(self, mapper: Mapper, pose, odom) -> None:
        """On the worker: the robot is at ``pose`` now; map -> odom follows at once."""
        mapper.set_pose(pose, odom)
        self._map_to_odom = mapper.map_to_odom
        self._send_map_to_odom()

    # -- outputs --------------------------------------------------------------------------------
    def _publish_map(self, mapper: Mapper, stamp) -> None:
        msg = occupancy_map_msg(mapper.occupancy_map(self.map_frame), stamp)
        self.map_pub.publish(msg)
        self.metadata_pub.publish(msg.info)
        self.graph_pub.publish(graph_markers(mapper.graph.poses, mapper.graph.edges, self.map_frame, stamp))

    def _send_map_to_odom(self) -> None:
        if self._map_to_odom is None or self._newest_ns < 0:
            return
        tf = TransformStamped()
        tf.header.frame_id, tf.child_frame_id = self.map_frame, self.odom_frame
        tf.header.stamp = post_dated(self._newest_ns, self.params.transform_tolerance)
        x, y, yaw = self._map_to_odom
        tf.transform.translation.x, tf.transform.translation.y = x, y
        r = tf.transform.rotation
        r.x, r.y, r.z, r.w = yaw_to_quaternion(yaw)
        self.tf_broadcaster.send_transform(tf)

    # -- services -------------------------------------------------------------------------------
    def _on_save_map(self, request: SaveMap.Request, response: SaveMap.Response) -> SaveMap.Response:
        """map_url is the files' name without suffix (Nav2's map_saver); empty mode and thresholds: trinary,
        0.65 and 0.25."""
        response.result = False
        if self.mapper is None or not self.mapper.scans:
            self.get_logger().error("save_map: no map yet")
            return response
        name = request.map_url or "map"
        occupied = request.occupied_thresh or 0.65
        free = request.free_thresh or 0.25
        try:
            occupancy = self._on_worker(self.mapper.occupancy_map, self.map_frame).result()
            image = save_map(occupancy, f"{name}.yaml", request.map_mode or "trinary", occupied, free)
        except (OSError, ValueError) as err:
            self.get_logger().error(f"save_map: {name}.yaml: {getattr(err, 'strerror', None) or err}")
            return response
        self.get_logger().info(f"save_map: wrote {name}.yaml and {image.name}")
        response.result = True
        return response

    def _on_serialize(self, request: SaveMap.Request, response: SaveMap.Response) -> SaveMap.Response:
        response.result = False
        if self.mapper is None:
            self.get_logger().error("serialize_map: no session to save")
            return response
        try:
            path = self._on_worker(session.save, self.mapper, request.map_url or "map").result()
        except (OSError, ValueError) as err:
            self.get_logger().error(f"serialize_map: {request.map_url or 'map'}: "
                                    f"{getattr(err, 'strerror', None) or err}")
            return response
        self.get_logger().info(f"serialize_map: wrote {path} ({len(self.mapper.scans)} nodes)")
        response.result = True
        return response

    def _on_deserialize(self, request: LoadMap.Request, response: LoadMap.Response) -> LoadMap.Response:
        """The session replaces the one in memory; the robot is where map_start_pose (or the session's start) says,
        until an initialpose."""
        try:
            mapper = self._on_worker(session.load, request.map_url, self.params).result()
        except ValueError as err:
            self.get_logger().error(f"deserialize_map: {err}; the current map stays")
            response.result = (LoadMap.Response.RESULT_MAP_DOES_NOT_EXIST if "no such file" in str(err)
                               else LoadMap.Response.RESULT_INVALID_MAP_DATA)
            return response
        self.mapper, self._map_to_odom = mapper, None
        stamp = self.get_clock().now().to_msg()
        self._publish_map(mapper, stamp)
        response.map = occupancy_map_msg(mapper.occupancy_map(self.map_frame), stamp)
        response.result = LoadMap.Response.RESULT_SUCCESS
        self.get_logger().info(f"deserialize_map: {len(mapper.scans)} nodes from {request.map_url}")
        return response

    def destroy_node(self):
        worker = getattr(self, "_worker", None)
        if worker is not None:
            worker.shutdown(wait=True, cancel_futures=True)
        return super().destroy_node()


class _Done:
    """A result already there, as a Future would hold it."""

    def __init__(self, value):
        self._value = value

    def result(self):
        return self._value


def main(args=None) -> int:
    return run_node("slam", SlamNode, args, (ValueError, ParameterError))


if __name__ == "__main__":
    sys.exit(main())
