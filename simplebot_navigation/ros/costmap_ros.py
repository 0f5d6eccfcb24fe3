"""Costmap2DROS: the ROS shell around a `Costmap`, living inside the move_base node (REFERENCE §2.2).

It reads `<name>.*` parameters of its node, subscribes the observation sources (and a StaticLayer's
map), waits for their transforms like a tf2 message filter, updates the layers at update_frequency
on the node's clock and publishes /<name>/costmap, /<name>/costmap_updates and /<name>/footprint.
Planners read `costmap` while holding `lock`.
"""

from __future__ import annotations

import contextvars
import logging
import math
import threading
import time
import weakref
from collections import deque
from dataclasses import dataclass, fields
from typing import NamedTuple

import numpy as np
import rclpy.logging
from geometry_msgs.msg import Polygon, PolygonStamped
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.time import Time
from sensor_msgs.msg import LaserScan, PointCloud2, PointField

from simplebot_navigation.costmap.cost_values import OCCUPANCY_GRID_TABLE
from simplebot_navigation.costmap.costmap import Costmap, warm_up
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.obstacle_layer import (Observation, ObservationSource, ObstacleLayer,
                                                         laser_scan_to_observation, point_cloud_to_observation)
from simplebot_navigation.costmap.params import parameter_specs
from simplebot_navigation.costmap.static_layer import StaticLayer
from simplebot_navigation.ros.conversions import occupancy_grid_msg, polygon_msg, quaternion_to_yaw
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.tf import (Buffer, ConnectivityException, ExtrapolationException, LookupException,
                                         TransformException, strip_frame)

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
UPDATES_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
#: messages a source may hold while their transform is not available (tf2_ros MessageFilter's 50)
MESSAGE_FILTER_QUEUE = 50
#: how often queued messages are retried while any wait
MESSAGE_FILTER_RETRY_S = 0.02
#: start-up: how often TF is tried, and how often the wait is reported (wall time)
TF_WAIT_POLL_S = 0.1
TF_WAIT_WARNING_PERIOD_S = 5.0


class RobotPose(NamedTuple):
    x: float
    y: float
    yaw: float
    stamp: Time


def _seconds(t: Time) -> float:
    return t.nanoseconds * 1e-9


# -- Python logging of the costmap package -> the logger of the node whose costmap is working -------
_ACTIVE: contextvars.ContextVar["Costmap2DROS | None"] = contextvars.ContextVar("active_costmap", default=None)
_process_lock = threading.Lock()
_process_prepared = False


class _NodeLogHandler(logging.Handler):
    """Forwards warnings of simplebot_navigation.costmap to the node logger, throttled per message."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self._fallback = rclpy.logging.get_logger("simplebot_navigation.costmap")
        self._last: dict[tuple, float] = {}

    def emit(self, record: logging.LogRecord) -> None:
        costmap = _ACTIVE.get()
        key = (id(costmap), record.name, record.msg)
        now = time.monotonic()
        if now - self._last.get(key, -math.inf) < 5.0:
            return
        self._last[key] = now
        text = record.getMessage()
        if costmap is None:
            self._fallback.warning(text)
        else:
            costmap.logger.warning(f"{costmap.name}: {text}")


def _prepare_process() -> None:
    """Once per process: route the costmap package's warnings, load its compiled kernels."""
    global _process_prepared
    with _process_lock:
        if not _process_prepared:
            logging.getLogger("simplebot_navigation.costmap").addHandler(_NodeLogHandler())
            warm_up()
            _process_prepared = True


class _Throttle:
    """Per-key wall-clock throttling (rclpy's throttle is per call site, not per message)."""

    def __init__(self):
        self._last: dict = {}

    def __call__(self, key, period: float) -> bool:
        now = time.monotonic()
        if now - self._last.get(key, -math.inf) < period:
            return False
        self._last[key] = now
        return True


# -- message -> numpy ------------------------------------------------------------------------------
def _rotation_matrix(q) -> np.ndarray:
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


_CLOUD_TYPES = {PointField.FLOAT32: "f4", PointField.FLOAT64: "f8"}


def point_cloud_xyz(msg: PointCloud2) -> np.ndarray:
    """(N, 3) float array of a PointCloud2's x, y, z fields (FLOAT32 or FLOAT64, any layout)."""
    by_name = {f.name: f for f in msg.fields}
    for axis in "xyz":
        field = by_name.get(axis)
        if field is None:
            raise ValueError(f"PointCloud2 has no '{axis}' field (fields: {sorted(by_name)})")
        if field.datatype not in _CLOUD_TYPES:
            raise ValueError(f"PointCloud2 field '{axis}' has datatype {field.datatype}; "
                             "only FLOAT32 (7) and FLOAT64 (8) are supported")
    endian = ">" if msg.is_bigendian else "<"
    dtype = np.dtype({"names": list("xyz"),
                      "formats": [endian + _CLOUD_TYPES[by_name[a].datatype] for a in "xyz"],
                      "offsets": [by_name[a].offset for a in "xyz"], "itemsize": msg.point_step})
    n_row = msg.width * msg.point_step
    raw = np.frombuffer(bytes(msg.data), dtype=np.uint8)
    if msg.height * msg.row_step > raw.size or n_row > msg.row_step:
        raise ValueError(f"PointCloud2 data holds {raw.size} bytes, less than its {msg.height} rows of "
                         f"{msg.row_step} bytes ({msg.width} points of {msg.point_step} bytes) need")
    rows = raw[:msg.height * msg.row_step].reshape(msg.height, msg.row_step)[:, :n_row]
    points = np.ascontiguousarray(rows).reshape(-1).view(dtype)
    return np.stack([points[a].astype(float) for a in "xyz"], axis=1)


class _SensorSubscriptions:
    """One subscription per sensor topic for all the costmaps of a node, each message handed to
    every costmap that reads the topic: the lab's two costmaps read the same two scans, and every
    subscription costs a message copy and an executor round."""

    _of_node: "weakref.WeakKeyDictionary[Node, _SensorSubscriptions]" = weakref.WeakKeyDictionary()

    def __init__(self, node: Node):
        self._node = weakref.ref(node)          # the registry must not keep its node alive
        self._topics: dict[tuple, tuple[object, list]] = {}

    @classmethod
    def of(cls, node: Node) -> "_SensorSubscriptions":
        if node not in cls._of_node:
            cls._of_node[node] = cls(node)
        return cls._of_node[node]

    def add(self, msg_type, topic: str, callback, callback_group) -> tuple:
        key = (msg_type, topic, id(callback_group))
        if key not in self._topics:
            callbacks: list = []

            def dispatch(msg, callbacks=callbacks):
                for handler in list(callbacks):
                    handler(msg)

            subscription = self._node().create_subscription(msg_type, topic, dispatch, qos_profile_sensor_data,
                                                            callback_group=callback_group)
            self._topics[key] = (subscription, callbacks)
        self._topics[key][1].append(callback)
        return key, callback

    def remove(self, token: tuple) -> None:
        key, callback = token
        subscription, callbacks = self._topics[key]
        callbacks.remove(callback)
        if not callbacks:
            self._node().destroy_subscription(subscription)
            del self._topics[key]


@dataclass
class _Pending:
    """A sensor message waiting for its transform."""
    msg: object
    frame: str
    arrival: float       # node clock, seconds
    last_error: str = ""


class _SourceInput:
    """Subscription and message-filter queue of one observation source."""

    def __init__(self, key: str, source: ObservationSource):
        self.key = key                 # '<layer>/<source>'
        self.source = source
        self.queue: deque[_Pending] = deque()
        self.subscription = None


class Costmap2DROS:
    """One costmap of a node: `Costmap2DROS(node, 'local_costmap', tf_buffer)`."""

    def __init__(self, node: Node, name: str, tf_buffer: Buffer, callback_group=None):
        self.node = node
        self.name = name
        self.tf = tf_buffer
        self.logger = node.get_logger()
        self.callback_group = callback_group
        self.lock = threading.RLock()
        self._queue_lock = threading.Lock()
        self._throttle = _Throttle()
        _prepare_process()

        given = given_parameter_tree(node, name)
        parents = [(node.get_fully_qualified_name(), given_parameter_tree(node))]
        self.cm = Costmap(name, given, parents=parents, clock=self._now_s)
        self.config = self.cm.config
        for warning in self.cm.warnings:
            self.logger.warning(warning)
        declare_defaults(node, self._resolved_tree(given, parents), prefix=name, specs=parameter_specs(self.config))

        c = self.config
        self.global_frame = c.global_frame
        self.robot_base_frame = c.robot_base_frame
        self.transform_tolerance = c.transform_tolerance
        self.last_pose_error = ""
        self._inputs = [_SourceInput(f"{layer}/{source.name}", source)
                        for layer, source in self.cm.observation_sources()]
        self._static_layers = [layer for layer in self.cm.layered.plugins if isinstance(layer, StaticLayer)]
        self._static_subscriptions: list = []
        self._active = False
        self._stopped = False
        self._paused = False
        self._tf_ready = False
        self._last_wait_warning = time.monotonic()

        # Publishing state: cells changed since the last publish, geometry of the last full grid.
        self._pending_window: tuple[int, int, int, int] | None = None
        self._sent_geometry = None
        self._new_subscriber = False
        self._last_publish_s = -math.inf

        self.costmap_pub = create_publisher(node, OccupancyGrid, f"/{name}/costmap", LATCHED,
                                            matched=self._on_costmap_matched, callback_group=callback_group)
        self.updates_pub = create_publisher(node, OccupancyGridUpdate, f"/{name}/costmap_updates", UPDATES_QOS)
        self.footprint_pub = create_publisher(node, PolygonStamped, self._topic(c.published_footprint_topic),
                                                   1)
        # costmap_2d subscribes geometry_msgs/Polygon on footprint_topic; under its default name that
        # topic is the published PolygonStamped one, which cannot carry both types, so it is skipped.
        self._footprint_sub = None
        if self._topic(c.footprint_topic) != self._topic(c.published_footprint_topic):
            self._footprint_sub = node.create_subscription(Polygon, self._topic(c.footprint_topic),
                                                           self._on_footprint, 1,
                                                           callback_group=callback_group)
        self._retry_timer = node.create_timer(MESSAGE_FILTER_RETRY_S, self._retry_pending,
                                              callback_group=callback_group)
        self._retry_timer.cancel()
        self._tf_wait_timer = node.create_timer(TF_WAIT_POLL_S, self._wait_for_tf, callback_group=callback_group,
                                                clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._update_period = 1.0 / c.update_frequency if c.update_frequency > 0 else 0.0
        self._update_timer = (node.create_timer(self._update_period, self._update_cycle,
                                                callback_group=callback_group)
                              if self._update_period > 0 else None)
        self._publish_period = 1.0 / c.publish_frequency if c.publish_frequency > 0 else 0.0
        # Subscribing now lets discovery run while TF is awaited; messages wait in the filter queues.
        self._activate()

    # -- parameters -------------------------------------------------------------------------------
    def _resolved_tree(self, given: dict, parents) -> dict:
        """The ROS 1 tree this costmap runs with, for declare_defaults (given values are kept)."""
        c = self.config
        tree = {key: getattr(c, key) for key in (
            "global_frame", "robot_base_frame", "rolling_window", "track_unknown_space",
            "always_send_full_costmap", "transform_tolerance", "update_frequency", "publish_frequency", "width",
            "height", "resolution", "origin_x", "origin_y", "footprint_padding", "footprint_topic",
            "published_footprint_topic")}
        searched = [given] + [values for _, values in parents]
        if not any("footprint" in ns for ns in searched):
            tree["footprint"] = "[]"
        if not any("robot_radius" in ns for ns in searched):
            tree["robot_radius"] = c.robot_radius
        tree["plugins"] = [{"name": p.name, "type": p.type} for p in c.plugins]
        for plugin in c.plugins:
            params = dict(plugin.params)
            if plugin.kind == "ObstacleLayer":
                sources = params.pop("sources")
                params["observation_sources"] = " ".join(s.name for s in sources)
                for s in sources:
                    params[s.name] = {f.name: getattr(s, f.name) for f in fields(s) if f.name != "name"}
            tree[plugin.name] = params
        return tree

    def _topic(self, topic: str) -> str:
        """A costmap-private topic: relative names live under /<name>/ (DESIGN §1)."""
        return topic if topic.startswith("/") else f"/{self.name}/{topic}"

    def _now_s(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    # -- start-up, start/stop ---------------------------------------------------------------------
    def _wait_for_tf(self) -> None:
        """Say every few seconds that global_frame <- robot_base_frame is missing; the ROS 1 constructor
        blocks here instead, which would stall the node's executor. Wall-clock, so it speaks even
        before /clock runs; the update cycle (sim time) is what starts updating, so that a lockstep
        run does not depend on how busy the machine is."""
        try:
            self.tf.lookup_transform(self.global_frame, self.robot_base_frame, Time())
        except TransformException as err:
            now = time.monotonic()
            if now - self._last_wait_warning >= TF_WAIT_WARNING_PERIOD_S:
                self._last_wait_warning = now
                self.logger.warning(
                    f"{self.name}: Timed out waiting for transform from {self.robot_base_frame} to "
                    f"{self.global_frame} to become available before running costmap, tf error: {err}")
            return
        self._tf_wait_timer.cancel()
        self.node.destroy_timer(self._tf_wait_timer)
        self._tf_wait_timer = None
        if self._update_timer is None:  # nothing else would start the costmap
            self._tf_ready = True

    def _activate(self) -> None:
        """Subscribe every source (ObstacleLayer::activate, which also restarts their staleness clocks)."""
        if self._active:
            return
        node, group = self.node, self.callback_group
        for inp in self._inputs:
            msg_type = LaserScan if inp.source.data_type == "LaserScan" else PointCloud2
            inp.subscription = _SensorSubscriptions.of(node).add(
                msg_type, inp.source.topic, lambda msg, inp=inp: self._on_sensor(inp, msg), group)
        for layer in self._static_layers:
            self._static_subscriptions.append(node.create_subscription(
                OccupancyGrid, layer.map_topic, lambda msg, layer=layer: self._on_map(layer, msg), LATCHED,
                callback_group=group))
            if layer.subscribe_to_updates:
                self._static_subscriptions.append(node.create_subscription(
                    OccupancyGridUpdate, layer.map_topic + "_updates",
                    lambda msg, layer=layer: self._on_map_update(layer, msg), UPDATES_QOS, callback_group=group))
        self._restart_staleness_clocks()
        self._active = True

    def _restart_staleness_clocks(self) -> None:
        now = self._now_s()
        with self.lock:
            for layer in self.cm.layered.plugins:
                if isinstance(layer, ObstacleLayer):
                    for buffer in layer.buffers.values():
                        buffer.reset_last_updated(now)

    def _deactivate(self) -> None:
        for inp in self._inputs:
            if inp.subscription is not None:
                _SensorSubscriptions.of(self.node).remove(inp.subscription)
                inp.subscription = None
            with self._queue_lock:
                inp.queue.clear()
        for sub in self._static_subscriptions:
            self.node.destroy_subscription(sub)
        self._static_subscriptions = []
        self._active = False

    def start(self) -> None:
        """Re-subscribe after stop() (move_base restarts its costmaps on a new goal)."""
        self._stopped = False
        self._paused = False
        self._activate()

    def stop(self) -> None:
        """Unsubscribe every source and stop updating."""
        self._stopped = True
        self._deactivate()

    def pause(self) -> None:
        """Stop updating but keep receiving data."""
        self._paused = True

    def resume(self) -> None:
        self._paused = False

    def destroy(self) -> None:
        """Release every subscription, timer and publisher (the node itself stays)."""
        self._deactivate()
        node = self.node
        for timer in (self._retry_timer, self._update_timer, self._tf_wait_timer):
            if timer is not None:
                node.destroy_timer(timer)
        if self._footprint_sub is not None:
            node.destroy_subscription(self._footprint_sub)
        for pub in (self.costmap_pub, self.updates_pub, self.footprint_pub):
            node.destroy_publisher(pub)

    # -- sensor input: a tf2 message filter ------------------------------------------------------
    def _on_sensor(self, inp: _SourceInput, msg) -> None:
        stamp = msg.header.stamp
        if stamp.sec < 0:
            if self._throttle(("bad stamp", inp.key), 5.0):
                self.logger.warning(f"{self.name}: Discarding message from [{inp.source.topic}]: header.stamp.sec "
                                    f"{stamp.sec} is negative")
            return
        frame = inp.source.sensor_frame or strip_frame(msg.header.frame_id)
        if not frame:
            if self._throttle(("empty frame", inp.key), 5.0):
                self.logger.warning(f"{self.name}: Discarding message from [{inp.source.topic}] due to empty "
                                    "frame_id (and no sensor_frame is configured)")
            return
        with self._queue_lock:
            if len(inp.queue) >= MESSAGE_FILTER_QUEUE:
                dropped = inp.queue.popleft()
                self._warn_drop(inp, dropped, "discarding message because the queue is full")
            inp.queue.append(_Pending(msg, frame, self._now_s()))
            self._process_queue(inp)
            if inp.queue and self._retry_timer.is_canceled():
                self._retry_timer.reset()

    def _retry_pending(self) -> None:
        with self._queue_lock:
            for inp in self._inputs:
                self._process_queue(inp)
            if not any(inp.queue for inp in self._inputs):
                self._retry_timer.cancel()

    def _process_queue(self, inp: _SourceInput) -> None:
        """Apply every queued message whose transform is available, in arrival order; drop those
        that waited longer than transform_tolerance. Caller holds _queue_lock."""
        if not inp.queue:
            return
        now = self._now_s()
        kept: deque[_Pending] = deque()
        for pending in inp.queue:
            try:
                tf = self.tf.lookup_transform(self.global_frame, pending.frame,
                                              Time.from_msg(pending.msg.header.stamp))
            except TransformException as err:
                pending.last_error = str(err)
                if now - pending.arrival > self.transform_tolerance:
                    self._warn_drop(inp, pending, pending.last_error)
                else:
                    kept.append(pending)
                continue
            self._apply(inp, pending.msg, tf)
        inp.queue = kept

    def _warn_drop(self, inp: _SourceInput, pending: _Pending, reason: str) -> None:
        """Throttled per source; quiet while the start-up wait for TF is being reported instead."""
        if self._tf_ready and self._throttle(("drop", inp.key), 5.0):
            stamp = _seconds(Time.from_msg(pending.msg.header.stamp))
            self.logger.warning(f"{self.name}: Message Filter dropping message on {inp.source.topic}: frame "
                                f"'{pending.frame}' at time {stamp:.3f} for reason '{reason}'")

    def _apply(self, inp: _SourceInput, msg, tf) -> None:
        """Turn a message plus its sensor -> global transform into an observation."""
        src = inp.source
        stamp = _seconds(Time.from_msg(msg.header.stamp))
        t = tf.transform.translation
        origin = np.array([t.x, t.y, t.z])
        rotation = _rotation_matrix(tf.transform.rotation)
        token = _ACTIVE.set(self)
        try:
            if isinstance(msg, LaserScan):
                local = laser_scan_to_observation(np.asarray(msg.ranges, dtype=np.float32), msg.angle_min,
                                                  msg.angle_increment, msg.range_min, msg.range_max,
                                                  (0.0, 0.0, 0.0, 0.0), stamp, src.obstacle_range,
                                                  src.raytrace_range, src.inf_is_valid)
                observation = Observation(origin, local.points @ rotation.T + origin, local.obstacle_range,
                                          local.raytrace_range, stamp, local.clear_points @ rotation.T + origin)
            else:
                try:
                    points = point_cloud_xyz(msg)
                except ValueError as err:
                    if self._throttle(("cloud", inp.key), 5.0):
                        self.logger.warning(f"{self.name}: dropping a cloud from {src.topic}: {err}")
                    return
                observation = point_cloud_to_observation(points @ rotation.T + origin, origin, stamp,
                                                         src.obstacle_range, src.raytrace_range)
            with self.lock:
                self.cm.add_observation(inp.key, observation)
        finally:
            _ACTIVE.reset(token)

    def _on_map(self, layer: StaticLayer, msg: OccupancyGrid) -> None:
        if layer.first_map_only and layer.map_received:
            return
        info = msg.info
        if abs(quaternion_to_yaw(info.origin.orientation)) > 1e-6:
            self.logger.warning(f"{self.name}: map on {layer.map_topic} has a rotated origin, which costmaps "
                                "ignore (as costmap_2d does)", once=True)
        data = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
        token = _ACTIVE.set(self)
        try:
            with self.lock:
                layer.incoming_map(data, info.resolution, info.origin.position.x, info.origin.position.y,
                                   msg.header.frame_id)
                self._touch_window(0, 0, self.costmap.size_x, self.costmap.size_y)
        except ValueError as err:
            self.logger.error(f"{self.name}: map on {layer.map_topic} rejected: {err}")
            return
        finally:
            _ACTIVE.reset(token)
        self.logger.info(f"{self.name}: received a {info.width} X {info.height} map at "
                         f"{info.resolution:.3f} m/pix on {layer.map_topic}")

    def _on_map_update(self, layer: StaticLayer, msg: OccupancyGridUpdate) -> None:
        data = np.asarray(msg.data, dtype=np.int8).reshape(msg.height, msg.width)
        try:
            with self.lock:
                layer.incoming_update(msg.x, msg.y, data)
        except ValueError as err:
            self.logger.error(f"{self.name}: map update on {layer.map_topic}_updates rejected: {err}")

    def _on_footprint(self, msg: Polygon) -> None:
        points = [(p.x, p.y) for p in msg.points]
        if len(points) < 3:
            self.logger.error(f"{self.name}: a footprint needs at least 3 points, got {len(points)} on "
                              f"{self._topic(self.config.footprint_topic)}; keeping the current one")
            return
        with self.lock:
            self.cm.set_unpadded_footprint(points)

    # -- robot pose ----------------------------------------------------------------------------------
    def _lookup_robot_pose(self) -> tuple[RobotPose | None, str]:
        try:
            tf = self.tf.lookup_transform(self.global_frame, self.robot_base_frame, Time())
        except LookupException as err:
            return None, f"No Transform available Error looking up robot pose: {err}"
        except ConnectivityException as err:
            return None, f"Connectivity Error looking up robot pose: {err}"
        except ExtrapolationException as err:
            return None, f"Extrapolation Error looking up robot pose: {err}"
        except TransformException as err:
            return None, f"Error looking up robot pose: {err}"
        stamp = Time.from_msg(tf.header.stamp)
        now = self._now_s()
        if now - _seconds(stamp) > self.transform_tolerance:
            return None, (f"Costmap2DROS transform timeout. Current time: {now:.4f}, global_pose stamp: "
                          f"{_seconds(stamp):.4f}, tolerance: {self.transform_tolerance:.4f}")
        t = tf.transform.translation
        return RobotPose(t.x, t.y, quaternion_to_yaw(tf.transform.rotation), stamp), ""

    def get_robot_pose(self) -> RobotPose | None:
        """Robot pose in global_frame from the latest TF, or None (reason in last_pose_error, logged
        at most once a second) when missing or older than transform_tolerance."""
        pose, reason = self._lookup_robot_pose()
        self.last_pose_error = reason
        if pose is not None or not self._throttle("pose", 1.0):
            return pose
        if reason.startswith("Costmap2DROS transform timeout"):
            self.logger.warning(f"{self.name}: {reason}")
        else:
            self.logger.error(f"{self.name}: {reason}")
        return None

    # -- update loop ---------------------------------------------------------------------------------
    def _update_cycle(self) -> None:
        if self._stopped or self._paused:
            return
        if not self._tf_ready:
            if not self.tf.can_transform(self.global_frame, self.robot_base_frame, Time()):
                return
            self._tf_ready = True
        if not self.cm.layered.initialized:
            # Sensors are judged from the first update on: before it, the wait for TF (and, under
            # use_sim_time, for /clock) is not their fault.
            self._restart_staleness_clocks()
        start = self._now_s()
        self.update_map_now()
        if (self._publish_period > 0 and self.cm.layered.initialized
                and start - self._last_publish_s >= self._publish_period):
            self.publish_costmap()
            self._last_publish_s = start
        took = self._now_s() - start
        if took > self._update_period and self._throttle("rate", 1.0):
            self.logger.warning(f"{self.name}: Map update loop missed its desired rate of "
                                f"{1.0 / self._update_period:.4f}Hz... the loop actually took {took:.4f} seconds")

    def update_map_now(self) -> bool:
        """One update: robot pose, layers, footprint; False when the pose is not available."""
        pose = self.get_robot_pose()
        if pose is None:
            return False
        token = _ACTIVE.set(self)
        try:
            with self.lock:
                self._update_static_transforms()
                self.cm.update_map(pose.x, pose.y, pose.yaw)
                window = self.cm.update_window
                if window is not None:
                    self._touch_window(*window)
                footprint = self.cm.oriented_footprint(pose.x, pose.y, pose.yaw)
        finally:
            _ACTIVE.reset(token)
        self.footprint_pub.publish(polygon_msg(footprint, self.global_frame, self.node.get_clock().now().to_msg()))
        self._warn_stale()
        return True

    def _update_static_transforms(self) -> None:
        """A rolling costmap reads a StaticLayer's map through TF (map frame <- global frame)."""
        if not self.cm.layered.rolling_window:
            return
        for layer in self._static_layers:
            if not layer.map_received:
                continue
            try:
                tf = self.tf.lookup_transform(layer.map_frame, self.global_frame, Time())
            except TransformException as err:
                if self._throttle(("static tf", layer.name), 5.0):
                    self.logger.error(f"{self.name}: static layer {layer.name}: {err}")
                continue
            t = tf.transform.translation
            layer.global_to_map = (t.x, t.y, quaternion_to_yaw(tf.transform.rotation))

    def _warn_stale(self) -> None:
        if self.cm.is_current():
            return
        now = self._now_s()
        for key in self.cm.stale_sources():
            layer_name, _, source_name = key.rpartition("/")
            buffer = self.cm.layered.layer(layer_name).buffers[source_name]
            if self._throttle(("stale", key), 2.0):
                self.logger.warning(
                    f"{self.name}: The {key} observation buffer ({buffer.source.topic}) has not been updated for "
                    f"{now - buffer.last_updated:.2f} seconds, and it should be updated every "
                    f"{buffer.source.expected_update_rate:.2f} seconds.")

    # -- publishing ----------------------------------------------------------------------------------
    def _touch_window(self, x0: int, y0: int, xn: int, yn: int) -> None:
        if self._pending_window is None:
            self._pending_window = (x0, y0, xn, yn)
        else:
            a = self._pending_window
            self._pending_window = (min(a[0], x0), min(a[1], y0), max(a[2], xn), max(a[3], yn))

    def _on_costmap_matched(self, info) -> None:
        """A new subscriber got the latched grid, which may be old: send it a current one."""
        if info.total_count_change > 0:
            self._new_subscriber = True

    def publish_costmap(self) -> None:
        """Costmap2DPublisher::publishCostmap: the full grid when the geometry changed (or always, or for
        a new subscriber), otherwise the cells changed since the last publish; nothing without
        subscribers (changes keep accumulating)."""
        if self.costmap_pub.get_subscription_count() == 0 and self.updates_pub.get_subscription_count() == 0:
            return
        stamp = self.node.get_clock().now().to_msg()
        with self.lock:
            master = self.costmap
            geometry = (master.size_x, master.size_y, master.resolution, master.origin_x, master.origin_y)
            if self.config.always_send_full_costmap or self._new_subscriber or geometry != self._sent_geometry:
                msg = occupancy_grid_msg(master.costmap, master.resolution, master.origin_x, master.origin_y,
                                         self.global_frame, stamp)
                self._sent_geometry = geometry
                self._new_subscriber = False
                self._pending_window = None
                self.costmap_pub.publish(msg)
                return
            window, self._pending_window = self._pending_window, None
            if window is None or window[2] <= window[0] or window[3] <= window[1]:
                return
            x0, y0, xn, yn = window
            update = OccupancyGridUpdate()
            update.header.frame_id = self.global_frame
            update.header.stamp = stamp
            update.x, update.y, update.width, update.height = x0, y0, xn - x0, yn - y0
            update.data = OCCUPANCY_GRID_TABLE[master.costmap[y0:yn, x0:xn]].ravel().tobytes()
        self.updates_pub.publish(update)

    # -- what planners, move_base and recoveries use --------------------------------------------------
    @property
    def costmap(self) -> Costmap2D:
        """The master grid; hold `lock` while reading it."""
        return self.cm.master

    @property
    def footprint(self) -> np.ndarray:
        """Padded footprint in the robot frame."""
        return self.cm.footprint

    def oriented_footprint(self, x: float, y: float, yaw: float) -> np.ndarray:
        return self.cm.oriented_footprint(x, y, yaw)

    @property
    def inscribed_radius(self) -> float:
        return self.cm.inscribed_radius

    @property
    def circumscribed_radius(self) -> float:
        return self.cm.circumscribed_radius

    @property
    def initialized(self) -> bool:
        """True after the first successful update."""
        return self.cm.layered.initialized

    def is_current(self) -> bool:
        return self.cm.is_current()

    def stale_sources(self) -> list[str]:
        return self.cm.stale_sources()

    def reset_layers(self) -> None:
        """clear_costmaps: every layer and the master back to their defaults."""
        with self.lock:
            self.cm.reset_layers()
            self._touch_window(0, 0, self.costmap.size_x, self.costmap.size_y)

    def clear_layers_outside(self, robot_x: float, robot_y: float, reset_distance: float, layer_names=None,
                             invert_area: bool = False) -> list[str]:
        """clear_costmap_recovery; see Costmap.clear_layers_outside."""
        with self.lock:
            return self.cm.clear_layers_outside(robot_x, robot_y, reset_distance, layer_names, invert_area)
