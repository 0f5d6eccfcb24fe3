"""What a Costmap2DROS reads: sensor messages through a tf2-style message filter, and StaticLayer maps.

A LaserScan or PointCloud2 waits in its source's queue until the transform from its frame to the
costmap's global frame at its stamp is known, then becomes an observation of the pure `CostmapCore`;
one that waits longer than transform_tolerance is dropped with the reason, as tf2_ros's
MessageFilter does.
"""

from __future__ import annotations

import threading
import weakref
from collections import deque
from dataclasses import dataclass

import numpy as np
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.time import Time
from sensor_msgs.msg import LaserScan, PointCloud2, PointField

from simplebot_navigation.costmap.observation import ObservationSource
from simplebot_navigation.costmap.static_layer import StaticLayer
from simplebot_navigation.geometry import quaternion_to_rotation_matrix
from simplebot_navigation.ros.conversions import stamp_seconds, yaw_of
from simplebot_navigation.ros.costmap.costmap_log import speaking_for
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.ros.tf import TransformException, strip_frame

UPDATES_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
#: messages a source may hold while their transform is not available (tf2_ros MessageFilter's 50)
MESSAGE_FILTER_QUEUE = 50
#: how often queued messages are retried while any wait
MESSAGE_FILTER_RETRY_S = 0.02


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


class CostmapInput:
    """The subscriptions of one Costmap2DROS (`owner`) and the message filter in front of its sensors."""

    def __init__(self, owner):
        self.owner = owner
        self._queue_lock = threading.Lock()
        self._sources = [_SourceInput(f"{layer}/{source.name}", source)
                         for layer, source in owner.cm.observation_sources()]
        self._static_layers = owner.cm.static_layers()
        self._static_subscriptions: list = []
        self._retry_timer = owner.node.create_timer(MESSAGE_FILTER_RETRY_S, self._retry_pending,
                                                    callback_group=owner.callback_group)
        self._retry_timer.cancel()

    def waiting(self) -> int:
        """Sensor messages held back for their transform."""
        with self._queue_lock:
            return sum(len(inp.queue) for inp in self._sources)

    # -- subscribing ----------------------------------------------------------------------------
    def subscribe(self) -> None:
        """Every observation source and every StaticLayer map (their layers' activate)."""
        node, group = self.owner.node, self.owner.callback_group
        for inp in self._sources:
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

    def unsubscribe(self) -> None:
        """Drop every subscription and every waiting message."""
        node = self.owner.node
        for inp in self._sources:
            if inp.subscription is not None:
                _SensorSubscriptions.of(node).remove(inp.subscription)
                inp.subscription = None
        self.clear_queues()
        for sub in self._static_subscriptions:
            node.destroy_subscription(sub)
        self._static_subscriptions = []

    def clear_queues(self) -> None:
        """Drop every message still waiting for its transform."""
        with self._queue_lock:
            for inp in self._sources:
                inp.queue.clear()

    def destroy(self) -> None:
        self.unsubscribe()
        self.owner.node.destroy_timer(self._retry_timer)

    # -- the message filter ---------------------------------------------------------------------
    def _on_sensor(self, inp: _SourceInput, msg) -> None:
        owner = self.owner
        stamp = msg.header.stamp
        if stamp.sec < 0:
            if owner.throttle(("bad stamp", inp.key), 5.0):
                owner.logger.warning(f"{owner.name}: Discarding message from [{inp.source.topic}]: header.stamp.sec "
                                     f"{stamp.sec} is negative")
            return
        frame = inp.source.sensor_frame or strip_frame(msg.header.frame_id)
        if not frame:
            if owner.throttle(("empty frame", inp.key), 5.0):
                owner.logger.warning(f"{owner.name}: Discarding message from [{inp.source.topic}] due to empty "
                                     "frame_id (and no sensor_frame is configured)")
            return
        with self._queue_lock:
            if len(inp.queue) >= MESSAGE_FILTER_QUEUE:
                dropped = inp.queue.popleft()
                self._warn_drop(inp, dropped, "discarding message because the queue is full")
            inp.queue.append(_Pending(msg, frame, owner.now_s()))
            self._process_queue(inp)
            if inp.queue and self._retry_timer.is_canceled():
                self._retry_timer.reset()

    def _retry_pending(self) -> None:
        with self._queue_lock:
            for inp in self._sources:
                self._process_queue(inp)
            if not any(inp.queue for inp in self._sources):
                self._retry_timer.cancel()

    def _process_queue(self, inp: _SourceInput) -> None:
        """Apply every queued message whose transform is available, in arrival order; drop those
        that waited longer than transform_tolerance. Caller holds _queue_lock."""
        if not inp.queue:
            return
        owner = self.owner
        now = owner.now_s()
        kept: deque[_Pending] = deque()
        for pending in inp.queue:
            try:
                tf = owner.tf.lookup_transform(owner.global_frame, pending.frame,
                                               Time.from_msg(pending.msg.header.stamp))
            except TransformException as err:
                pending.last_error = str(err)
                if now - pending.arrival > owner.transform_tolerance:
                    self._warn_drop(inp, pending, pending.last_error)
                else:
                    kept.append(pending)
                continue
            self._apply(inp, pending.msg, tf)
        inp.queue = kept

    def _warn_drop(self, inp: _SourceInput, pending: _Pending, reason: str) -> None:
        """Throttled per source; quiet while the start-up wait for TF is being reported instead."""
        owner = self.owner
        if owner.tf_ready and owner.throttle(("drop", inp.key), 5.0):
            stamp = stamp_seconds(Time.from_msg(pending.msg.header.stamp))
            owner.logger.warning(f"{owner.name}: Message Filter dropping message on {inp.source.topic}: frame "
                                 f"'{pending.frame}' at time {stamp:.3f} for reason '{reason}'")

    def _apply(self, inp: _SourceInput, msg, tf) -> None:
        """A message plus its sensor -> global transform becomes an observation of the costmap."""
        owner = self.owner
        src = inp.source
        stamp = stamp_seconds(Time.from_msg(msg.header.stamp))
        t = tf.transform.translation
        origin = np.array([t.x, t.y, t.z])
        q = tf.transform.rotation
        rotation = quaternion_to_rotation_matrix(q.x, q.y, q.z, q.w)
        with speaking_for(owner, src.topic):
            if isinstance(msg, LaserScan):
                with owner.lock:
                    owner.cm.add_laser_scan(inp.key, np.asarray(msg.ranges, dtype=np.float32), msg.angle_min,
                                            msg.angle_increment, msg.range_min, msg.range_max, origin, stamp,
                                            sensor_rotation=rotation)
                if owner.scan_observer is not None:
                    owner.scan_observer(src, msg, tf)
                return
            try:
                points = point_cloud_xyz(msg)
            except ValueError as err:
                if owner.throttle(("cloud", inp.key), 5.0):
                    owner.logger.warning(f"{owner.name}: dropping a cloud from {src.topic}: {err}")
                return
            with owner.lock:
                owner.cm.add_point_cloud(inp.key, points @ rotation.T + origin, origin, stamp)

    # -- StaticLayer maps -----------------------------------------------------------------------
    def _on_map(self, layer: StaticLayer, msg: OccupancyGrid) -> None:
        owner = self.owner
        if layer.first_map_only and layer.map_received:
            return
        info = msg.info
        if abs(yaw_of(info.origin.orientation)) > 1e-6:
            owner.logger.warning(f"{owner.name}: map on {layer.map_topic} has a rotated origin, which costmaps "
                                 "ignore (as costmap_2d does)", once=True)
        data = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
        try:
            with speaking_for(owner), owner.lock:
                layer.incoming_map(data, info.resolution, info.origin.position.x, info.origin.position.y,
                                   msg.header.frame_id)
                owner.publisher.touch_all()
        except ValueError as err:
            owner.logger.error(f"{owner.name}: map on {layer.map_topic} rejected: {err}")
            return
        owner.logger.info(f"{owner.name}: received a {info.width} X {info.height} map at "
                          f"{info.resolution:.3f} m/pix on {layer.map_topic}")

    def _on_map_update(self, layer: StaticLayer, msg: OccupancyGridUpdate) -> None:
        owner = self.owner
        data = np.asarray(msg.data, dtype=np.int8).reshape(msg.height, msg.width)
        try:
            with owner.lock:
                layer.incoming_update(msg.x, msg.y, data)
        except ValueError as err:
            owner.logger.error(f"{owner.name}: map update on {layer.map_topic}_updates rejected: {err}")
