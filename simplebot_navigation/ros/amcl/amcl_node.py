"""amcl: localization.Amcl behind ROS 1 amcl's topics, frames and services (docs/reference.md §8).

In: the map on ``map`` (latched), the scans of every topic in ``scan_topics`` (both lidars; amcl's single ``scan``
topic, several lasers' frames), the odometry as TF (``odom_frame_id`` -> ``base_frame_id`` at each scan's stamp),
``initialpose``. Out: ``global_frame_id`` -> ``odom_frame_id`` on /tf, post-dated by transform_tolerance and sent
again with every scan; ``amcl_pose`` after each filter update; ``particle_cloud`` while anyone listens. Services
``global_localization`` and ``request_nomotion_update`` (std_srvs/Empty).

A scan waits (at most MAX_SCAN_WAIT_S) until the odometry transform at its stamp is known, as a tf2 message filter
would. Scans that go back in time by more than TIME_JUMP_BACK_S (a restarted simulation) restart the filter around
its last estimate and clear the transform buffer. Without scans nothing is published, so map -> odom goes stale and
move_base stops the robot.
"""

from __future__ import annotations

import math
import os
import sys
from collections import deque

import numpy as np
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import OccupancyGrid
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty

from simplebot_navigation.geometry import compose2, inverse2, yaw_to_quaternion
from simplebot_navigation.localization.amcl import Amcl
from simplebot_navigation.localization import pose_state
from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.parameters import ParameterError, fields_of
from simplebot_navigation.parameters.spec import Param
from simplebot_navigation.ros.amcl import amcl_messages as messages
from simplebot_navigation.ros.conversions import checked_occupancy_map, pose_array_msg, transform_to_xyyaw
from simplebot_navigation.log_throttle import Throttle
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import declare_defaults, descriptor, given_parameter_tree
from simplebot_navigation.ros.lifecycle_state import serve_lifecycle_state
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.qos import LATCHED, SERVICE_QOS
from simplebot_navigation.ros.tf import (Buffer, ExtrapolationException, TransformBroadcaster, TransformException,
                                         TransformListener, strip_frame)

#: ours: the laser topics amcl reads (ROS 1's amcl reads one ``scan`` topic)
SCAN_TOPICS = Param((str, list), "front_laser/front_scan back_laser/back_scan", "",
                    "the LaserScan topics amcl weighs the particles with (1 to 8, space-separated or a list)",
                    dynamic=False)
MAX_SCAN_TOPICS = 8
#: a scan whose odometry transform is not known this long after its stamp is dropped
MAX_SCAN_WAIT_S = 0.5
#: scans held while their transform is not known
MAX_PENDING = 16
#: a scan stamped this far ahead of the node's clock is dropped (it would wait for its transform for ever)
MAX_SCAN_AHEAD_S = 1.0
#: a scan stamped this much before the newest one means time went back
TIME_JUMP_BACK_S = 1.0
RETRY_PERIOD_S = 0.02
#: the launch's run folder (set by the launcher), where the node keeps its last estimate for a respawn
RUN_DIR_ENV = "SIMPLEBOT_RUN_DIR"


class AmclNode(SetUpNode):
    def __init__(self, **kwargs):
        kwargs.setdefault("automatically_declare_parameters_from_overrides", True)
        super().__init__("amcl", **kwargs)

    def _set_up(self) -> None:
        tree = given_parameter_tree(self)
        topics = SCAN_TOPICS.check(tree.pop("scan_topics", SCAN_TOPICS.default), "amcl parameter 'scan_topics'")
        topics = topics.split() if isinstance(topics, str) else topics
        if not 1 <= len(topics) <= MAX_SCAN_TOPICS or not all(isinstance(t, str) and t for t in topics):
            raise ValueError(f"amcl parameter 'scan_topics': 1 to {MAX_SCAN_TOPICS} topic names, got {topics!r}")
        self.params = AmclParams.from_params(tree)
        for warning in self.params.warnings:
            self.get_logger().warn(warning)
        specs = fields_of(AmclParams)
        declare_defaults(self, {name: getattr(self.params, name) for name in specs}, specs=specs)
        if not self.has_parameter("scan_topics"):
            self.declare_parameter("scan_topics", " ".join(topics), descriptor(SCAN_TOPICS))
        self.topics = topics
        self.global_frame = strip_frame(self.params.global_frame_id)
        self.odom_frame = strip_frame(self.params.odom_frame_id)
        self.base_frame = strip_frame(self.params.base_frame_id)
        self.amcl: Amcl | None = None               # until the first map
        self._pending_pose: tuple | None = None     # an initial pose that came before the map
        self._pending: deque = deque(maxlen=MAX_PENDING)
        self._throttle = Throttle()
        self._sensor_poses: dict[str, tuple[float, float, float]] = {}
        self._map_to_odom: tuple[float, float, float] | None = None
        self._newest = -math.inf
        self._pose_saved_at = -math.inf
        self._state_path, self._resume = self._saved_state()
        self.tf = Buffer(node=self)
        self._listener = TransformListener(self.tf, self)
        self.tf_broadcaster = TransformBroadcaster(self)
        self.pose_pub = create_publisher(self, PoseWithCovarianceStamped, "amcl_pose", LATCHED)
        self.cloud_pub = create_publisher(self, PoseArray, "particle_cloud", 1)
        self.create_subscription(OccupancyGrid, "map", self._on_map, LATCHED)
        self.create_subscription(PoseWithCovarianceStamped, "initialpose", self._on_initial_pose, 10)
        for topic in topics:
            self.create_subscription(LaserScan, topic, lambda msg, t=topic: self._on_scan(t, msg),
                                     qos_profile_sensor_data)
        self.create_service(Empty, "global_localization", self._on_global_localization, qos_profile=SERVICE_QOS)
        self.create_service(Empty, "request_nomotion_update", self._on_nomotion_update, qos_profile=SERVICE_QOS)
        # Nav2's scripts wait for amcl/get_state to say active: so it does once it has a map and places the robot.
        serve_lifecycle_state(self, "~", lambda: self.amcl is not None and self._map_to_odom is not None)
        self._retry = self.create_timer(RETRY_PERIOD_S, self._process_pending)
        self._retry.cancel()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(f"waiting for a map on {self.resolve_topic_name('map')}; scans from "
                               f"{', '.join(self.resolve_topic_name(t) for t in topics)}")

    def _saved_state(self) -> tuple[str | None, pose_state.PoseState | None]:
        """Where this node keeps its last estimate (in the launch's run folder, when the launcher started it), and
        the estimate a previous run of it left there, if any and valid."""
        run_dir = os.environ.get(RUN_DIR_ENV, "")
        if not run_dir:
            return None, None
        path = os.path.join(run_dir, self.get_fully_qualified_name().strip("/").replace("/", "__") + ".pose.yaml")
        try:
            state = pose_state.load(path, self.global_frame)
        except ValueError as err:
            self.get_logger().warn(f"saved pose ignored: {err}; starting from initial_pose_*")
            return path, None
        if state is not None:
            self.get_logger().info(f"restarted: resuming from the estimate saved at {state.stamp:.2f} s in {path}")
        return path, state

    # -- parameters -----------------------------------------------------------------------------
    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Checked in full (every value, and the values together) before anything changes; frames, models, the
        seed and the topics are read at start-up only."""
        specs = fields_of(AmclParams)
        fixed = [p.name for p in params if p.name in ("scan_topics", "use_sim_time")
                 or (p.name in specs and not specs[p.name].dynamic)]
        if fixed:
            return SetParametersResult(successful=False, reason=f"{', '.join(fixed)}: requires restart")
        unknown = [p.name for p in params if p.name not in specs]
        if unknown:
            return SetParametersResult(successful=False, reason=f"{', '.join(unknown)}: not a parameter of amcl")
        values = {name: getattr(self.params, name) for name in specs}
        values.update({p.name: p.value for p in params})
        try:
            new = AmclParams.from_params(values)
        except (ParameterError, ValueError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        except Exception as err:   # noqa: BLE001 -- any failure of a check is a refusal with its reason
            return SetParametersResult(successful=False, reason=f"{type(err).__name__}: {err}")
        if self.amcl is not None:
            try:
                self.amcl.reconfigure(new)
            except (ParameterError, ValueError, MemoryError) as err:
                return SetParametersResult(successful=False, reason=f"{type(err).__name__}: {err}")
        self.params = new
        return SetParametersResult(successful=True)

    # -- the map and the initial pose -----------------------------------------------------------
    def _on_map(self, msg: OccupancyGrid) -> None:
        if self.amcl is not None and self.params.first_map_only:
            return
        try:
            grid = checked_occupancy_map(msg, "amcl")
        except ValueError as err:
            self.get_logger().warn(f"map ignored: {err}; "
                                   + ("the old map stays" if self.amcl is not None else "still no map"))
            return
        if strip_frame(msg.header.frame_id) not in ("", self.global_frame):
            self.get_logger().warn(f"map is in frame '{msg.header.frame_id}', not global_frame_id "
                                   f"'{self.global_frame}': it is taken as {self.global_frame}")
        try:
            if self.amcl is None:
                self.amcl, free = Amcl(self.params, grid.data, grid.resolution, grid.origin), True
            else:               # a new map: the same belief, round the last estimate with its spread
                self.amcl, free = self.amcl.on_new_map(grid.data, grid.resolution, grid.origin)
        except ValueError as err:      # a non-finite origin, no free cell: the filter stays as it was
            self.get_logger().warn(f"map ignored: {err}")
            return
        p = self.amcl.params
        self.get_logger().info(f"map of {grid.width} x {grid.height} cells; {len(self.amcl.particles)} particles "
                               f"around ({p.initial_pose_x:.2f}, {p.initial_pose_y:.2f}, {p.initial_pose_a:.2f})")
        if not free:
            self.get_logger().warn(f"the estimate ({p.initial_pose_x:.2f}, {p.initial_pose_y:.2f}) is not in free "
                                   "space of the new map: the particles start round it all the same; give an "
                                   "initial pose or call global_localization")
        if self._pending_pose is not None:
            self._set_pose(*self._pending_pose)
            self._pending_pose = None

    def _on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        try:
            x, y, yaw, covariance = messages.initial_pose(msg)
            frame = strip_frame(msg.header.frame_id) or self.global_frame
            if frame != self.global_frame:      # e.g. a tool whose fixed frame is odom
                tf = self.tf.lookup_transform(self.global_frame, frame, Time())
                frame_pose = transform_to_xyyaw(tf)
                x, y, yaw = compose2(frame_pose, (x, y, yaw))
                c, s = math.cos(frame_pose[2]), math.sin(frame_pose[2])
                rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
                covariance = rotation @ covariance @ rotation.T
        except (ValueError, TransformException) as err:
            self.get_logger().warn(f"initialpose ignored: {err}")
            return
        self._resume = None         # a pose given now wins over the one a previous run saved
        if self.amcl is None:
            self._pending_pose = (x, y, yaw, covariance)
            return
        self._set_pose(x, y, yaw, covariance)

    def _set_pose(self, x: float, y: float, yaw: float, covariance) -> None:
        """A pose on the map with a spread no wider than it, or a warning and nothing changes."""
        amap = self.amcl.map
        col, row = amap.to_grid(np.array([[x, y, 0.0]]))[0, :2]
        extent = amap.resolution * math.hypot(amap.width, amap.height)
        if not (0 <= col < amap.width and 0 <= row < amap.height):
            self.get_logger().warn(f"initialpose ignored: ({x:.3g}, {y:.3g}) is outside the map")
            return
        if max(covariance[0][0], covariance[1][1]) > extent ** 2 or covariance[2][2] > (2 * math.pi) ** 2:
            self.get_logger().warn("initialpose ignored: pose.covariance is wider than the map (or than a turn)")
            return
        try:
            self.amcl.set_initial_pose(x, y, yaw, covariance)
        except ValueError as err:
            self.get_logger().warn(f"initialpose ignored: {err}")
            return
        self.get_logger().info(f"initial pose ({x:.3f}, {y:.3f}, {math.degrees(yaw):.1f} deg) in {self.global_frame}")

    def _on_global_localization(self, _request, response):
        if self.amcl is None:
            self.get_logger().warn("global_localization: no map yet")
            return response
        self.amcl.global_localization()
        seeded = "; the next scans seed them round the scan matcher's candidates" if self.amcl.relocalizer.pending \
            else ""
        self.get_logger().info(f"global localization: {len(self.amcl.particles)} particles over the free space"
                               + seeded)
        return response

    def _on_nomotion_update(self, _request, response):
        if self.amcl is not None:
            self.amcl.request_nomotion_update()
        return response

    # -- scans ----------------------------------------------------------------------------------
    def _on_scan(self, topic: str, msg: LaserScan) -> None:
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        now = self.get_clock().now().nanoseconds * 1e-9
        if msg.header.stamp.sec < 0 or stamp > now + MAX_SCAN_AHEAD_S:
            self.get_logger().warn(f"{topic}: scan dropped: stamp {stamp:.3f} s is negative or more than "
                                   f"{MAX_SCAN_AHEAD_S:g} s ahead of the clock ({now:.3f} s)",
                                   throttle_duration_sec=5.0)
            return
        self._pending.append((topic, msg))
        self._process_pending()

    def _process_pending(self) -> None:
        """Scans in order of arrival, each once the odometry at its stamp is known (or dropped after a while)."""
        while self._pending:
            topic, msg = self._pending[0]
            if not self._try_scan(topic, msg):
                waited = self.get_clock().now().nanoseconds * 1e-9 - Time.from_msg(msg.header.stamp).nanoseconds * 1e-9
                if waited <= MAX_SCAN_WAIT_S:
                    if self._retry.is_canceled():
                        self._retry.reset()
                    return
                self.get_logger().warn(f"{topic}: scan dropped: no {self.odom_frame} -> {self.base_frame} transform "
                                       f"at its stamp after {waited:.2f} s", throttle_duration_sec=5.0)
            self._pending.popleft()
        self._retry.cancel()

    def _try_scan(self, topic: str, msg: LaserScan) -> bool:
        """Use one scan; False while its odometry transform is still to come."""
        stamp = Time.from_msg(msg.header.stamp)
        t = stamp.nanoseconds * 1e-9
        if self.amcl is None:
            self.get_logger().warn("no map yet: scans are not used", throttle_duration_sec=5.0)
            return True
        if t < self._newest - TIME_JUMP_BACK_S:
            self._restart_after_time_jump(topic, t)
        try:
            scan = messages.range_scan(msg, self._sensor_pose(strip_frame(msg.header.frame_id)))
        except (ValueError, TransformException) as err:
            self._warn_dropped(topic, msg, err)
            return True
        try:
            odom = transform_to_xyyaw(self.tf.lookup_transform(self.odom_frame, self.base_frame, stamp))
        except ExtrapolationException:
            return False
        except TransformException as err:
            self._warn_dropped(topic, msg, err)
            return True
        if self._resume is not None:
            self._resume_saved(t, odom)
        try:
            self.amcl.odometry_update(odom)
            updated = self.amcl.sensor_update([scan], source=topic, stamp=t)
        except ValueError as err:
            self._warn_dropped(topic, msg, err)
            return True
        self._newest = max(self._newest, t)
        if updated or self._map_to_odom is None:
            self._publish_estimate(odom, msg.header.stamp)
        self._send_map_to_odom(stamp.nanoseconds)
        return True

    def _resume_saved(self, t: float, odom: tuple[float, float, float]) -> None:
        """The first scan after a restart: the saved map -> odom with the odometry now is where the robot is (the
        odometry kept running while this node was down), unless the scans are older than the saved estimate."""
        state, self._resume = self._resume, None
        if t < state.stamp - TIME_JUMP_BACK_S:
            self.get_logger().warn(f"saved pose ignored: it is of {state.stamp:.2f} s, the scans of {t:.2f} s (the "
                                   "simulation restarted); starting from initial_pose_*")
            return
        self._set_pose(*compose2(state.map_to_odom, odom), np.diag(state.variances))

    def _warn_dropped(self, topic: str, msg: LaserScan, err: Exception) -> None:
        """Every 5 s at most per topic, frame and kind of problem: a new problem is told at once, a repeated one
        does not flood the log (rclpy's own throttle is per call site and would hide the new one)."""
        if self._throttle((topic, msg.header.frame_id, type(err).__name__), 5.0):
            self.get_logger().warn(f"{topic}: scan dropped: {err}")

    def _sensor_pose(self, frame: str) -> tuple[float, float, float]:
        if frame not in self._sensor_poses:
            tf = self.tf.lookup_transform(self.base_frame, frame, Time())
            self._sensor_poses[frame] = transform_to_xyyaw(tf)
        return self._sensor_poses[frame]

    def _restart_after_time_jump(self, topic: str, t: float) -> None:
        self.get_logger().warn(f"{topic}: time went back from {self._newest:.2f} s to {t:.2f} s: the filter "
                               "restarts around its last estimate and the transform buffer is cleared")
        last, p = self.amcl.estimate(), self.params
        self.tf.clear()
        self._sensor_poses.clear()
        self.amcl.set_initial_pose(last.x, last.y, last.yaw, np.diag([p.initial_cov_xx, p.initial_cov_yy,
                                                                      p.initial_cov_aa]))
        self._newest = -math.inf

    # -- outputs --------------------------------------------------------------------------------
    def _publish_estimate(self, odom: tuple[float, float, float], stamp) -> None:
        estimate = self.amcl.estimate()
        self._map_to_odom = compose2((estimate.x, estimate.y, estimate.yaw), inverse2(odom))
        self._save_pose(estimate, Time.from_msg(stamp).nanoseconds * 1e-9)
        self.pose_pub.publish(messages.estimate_msg(estimate, self.global_frame, stamp))
        if self.cloud_pub.get_subscription_count():
            self.cloud_pub.publish(pose_array_msg(self.amcl.particles, self.global_frame, stamp))

    def _save_pose(self, estimate, t: float) -> None:
        """save_pose_rate: the estimate becomes the initial_pose_* and initial_cov_* parameters, so that a restart
        of the filter (time going back) starts from it, and map -> odom with the spread goes to the state file, from
        which a respawned node starts."""
        rate, now = self.params.save_pose_rate, self.get_clock().now().nanoseconds * 1e-9
        if rate <= 0 or now - self._pose_saved_at < 1.0 / rate:
            return
        self._pose_saved_at = now
        cov = estimate.covariance
        values = {"initial_pose_x": estimate.x, "initial_pose_y": estimate.y, "initial_pose_a": estimate.yaw,
                  "initial_cov_xx": cov[0, 0], "initial_cov_yy": cov[1, 1], "initial_cov_aa": cov[2, 2]}
        if not all(math.isfinite(v) and (not name.startswith("initial_cov") or v > 0) for name, v in values.items()):
            return
        self.set_parameters([Parameter(name, value=float(v)) for name, v in values.items()])
        if self._state_path is None:
            return
        state = pose_state.PoseState(self.global_frame, t, self._map_to_odom, (cov[0, 0], cov[1, 1], cov[2, 2]))
        try:
            pose_state.save(self._state_path, state)
        except OSError as err:
            if self._throttle(("state file", type(err).__name__), 60.0):
                self.get_logger().warn(f"{self._state_path}: the estimate cannot be saved ({err.strerror or err}); a "
                                       "respawned amcl would start from initial_pose_*")

    def _send_map_to_odom(self, stamp_ns: int) -> None:
        if self._map_to_odom is None or not self.params.tf_broadcast:
            return
        tf = TransformStamped()
        tf.header.frame_id, tf.child_frame_id = self.global_frame, self.odom_frame
        tf.header.stamp = messages.post_dated(stamp_ns, self.params.transform_tolerance)
        x, y, yaw = self._map_to_odom
        tf.transform.translation.x, tf.transform.translation.y = x, y
        r = tf.transform.rotation
        r.x, r.y, r.z, r.w = yaw_to_quaternion(yaw)
        self.tf_broadcaster.send_transform(tf)


def main(args=None) -> int:
    return run_node("amcl", AmclNode, args, (ValueError, ParameterError))


if __name__ == "__main__":
    sys.exit(main())
