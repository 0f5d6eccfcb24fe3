"""A small tf2_ros: a time-stamped transform buffer with the API and error wording users know.

tf2_ros has no PyPI wheel. This keeps a history per edge of the frame tree,
interpolates (linear translation, slerp rotation), chains through the common
ancestor, and raises tf2's three lookup errors. Frame ids with a leading '/'
(as the lab's configs write them) are accepted and stripped.
"""

from __future__ import annotations

import bisect
import math
import threading
from dataclasses import dataclass

from geometry_msgs.msg import PoseStamped, TransformStamped
from rclpy.clock import JumpThreshold, TimeJump
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from tf2_msgs.msg import TFMessage

from simplebot_navigation.geometry import compose, interpolate, inverse
from simplebot_navigation.ros.publishers import create_publisher


class TransformException(Exception):
    """Base of the lookup errors, as tf2.TransformException."""


class LookupException(TransformException):
    pass


class ConnectivityException(TransformException):
    pass


class ExtrapolationException(TransformException):
    pass


class InvalidArgumentException(TransformException):
    pass


TF_QOS = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)
TF_STATIC_LISTENER_QOS = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST,
                                    reliability=ReliabilityPolicy.RELIABLE,
                                    durability=DurabilityPolicy.TRANSIENT_LOCAL)


def strip_frame(frame_id: str) -> str:
    return frame_id[1:] if frame_id.startswith("/") else frame_id


def _to_tuple(tf: TransformStamped):
    t, r = tf.transform.translation, tf.transform.rotation
    return (t.x, t.y, t.z, r.x, r.y, r.z, r.w)


def _stamp_ns(stamp) -> int:
    if isinstance(stamp, Time):
        return stamp.nanoseconds
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _fmt(ns: int) -> str:
    return f"{ns / 1e9:.6f}"


@dataclass
class _Edge:
    parent: str
    static: bool
    stamps: list[int]
    values: list[tuple]
    authority: str = ""


class Buffer:
    """tf2_ros.Buffer: lookup_transform(target, source, time, timeout), can_transform, transform poses."""

    def __init__(self, cache_time: Duration | None = None, node: Node | None = None):
        self.cache_ns = (cache_time or Duration(seconds=10.0)).nanoseconds
        self._edges: dict[str, _Edge] = {}
        self._cond = threading.Condition()
        self._node = node
        if node is not None:
            # As tf2_ros: a backward jump of the node's clock (a restarted simulator, a looped bag) empties the
            # buffer, or every transform of the new timeline would be "extrapolation into the past".
            self._jump_handle = node.get_clock().create_jump_callback(
                JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False),
                post_callback=self._on_time_jump)

    def _on_time_jump(self, jump: TimeJump) -> None:
        self.clear()
        self._node.get_logger().warn(f"time jumped back by {-jump.delta.nanoseconds * 1e-9:.2f} s: "
                                     "transform buffer cleared (static transforms kept)")

    # -- filling ----------------------------------------------------------------------------
    def set_transform(self, transform: TransformStamped, authority: str) -> bool:
        return self._insert(transform, authority, static=False)

    def set_transform_static(self, transform: TransformStamped, authority: str) -> bool:
        return self._insert(transform, authority, static=True)

    def _unusable(self, parent: str, child: str, value, stamp, static: bool) -> str:
        """Why a transform must not enter the buffer: one from the far future would evict every
        transform of its edge and make the real ones look too old to keep, for good."""
        if not parent or not child or parent == child:
            return "frame ids must be non-empty and differ"
        if not all(math.isfinite(v) for v in value):
            return "it holds a NaN or inf"
        if stamp.sec < 0:
            return f"its stamp is negative ({stamp.sec} s)"
        now = self._node.get_clock().now().nanoseconds if self._node is not None else 0
        if not static and now > 0:          # 0: simulated time has not started yet
            ahead = _stamp_ns(stamp) - now
            if ahead > self.cache_ns:
                return f"its stamp is {ahead * 1e-9:.1f} s ahead of this node's clock"
        return ""

    def _insert(self, transform: TransformStamped, authority: str, static: bool) -> bool:
        parent = strip_frame(transform.header.frame_id)
        child = strip_frame(transform.child_frame_id)
        value = _to_tuple(transform)
        reason = self._unusable(parent, child, value, transform.header.stamp, static)
        if reason:
            if self._node is not None:
                self._node.get_logger().warn(
                    f"ignoring transform {parent!r} -> {child!r} from {authority or 'unknown'}: {reason}",
                    throttle_duration_sec=5.0)
            return False
        stamp = _stamp_ns(transform.header.stamp)
        with self._cond:
            edge = self._edges.get(child)
            if edge is None or edge.static != static or edge.parent != parent:
                edge = self._edges[child] = _Edge(parent, static, [], [], authority)
            if static:
                edge.stamps, edge.values = [stamp], [value]
            else:
                if edge.stamps and stamp < edge.stamps[-1] - self.cache_ns:
                    return False
                i = bisect.bisect_right(edge.stamps, stamp)
                if i > 0 and edge.stamps[i - 1] == stamp:
                    edge.values[i - 1] = value
                else:
                    edge.stamps.insert(i, stamp)
                    edge.values.insert(i, value)
                cutoff = edge.stamps[-1] - self.cache_ns
                drop = bisect.bisect_left(edge.stamps, cutoff)
                if drop:
                    del edge.stamps[:drop], edge.values[:drop]
            edge.authority = authority
            self._cond.notify_all()
        return True

    def clear(self) -> None:
        """Forget every dynamic transform; static ones stay, as in tf2."""
        with self._cond:
            self._edges = {child: edge for child, edge in self._edges.items() if edge.static}

    # -- lookup -----------------------------------------------------------------------------
    def _chain(self, frame: str) -> list[str]:
        chain = [frame]
        while chain[-1] in self._edges:
            chain.append(self._edges[chain[-1]].parent)
            if len(chain) > 1000:
                raise LookupException(f"frame {frame} is part of a loop in the transform tree")
        return chain

    def _known(self, frame: str) -> bool:
        return frame in self._edges or any(e.parent == frame for e in self._edges.values())

    def _edge_at(self, child: str, t: int, target: str, source: str):
        edge = self._edges[child]
        if edge.static:
            return edge.values[0]
        stamps = edge.stamps
        if len(stamps) == 1:
            if t == stamps[0]:
                return edge.values[0]
            raise ExtrapolationException(
                f"Lookup would require extrapolation at time {_fmt(t)}, but only time {_fmt(stamps[0])} is in the "
                f"buffer, when looking up transform from frame [{source}] to frame [{target}]")
        if t > stamps[-1]:
            raise ExtrapolationException(
                f"Lookup would require extrapolation into the future.  Requested time {_fmt(t)} but the latest data "
                f"is at time {_fmt(stamps[-1])}, when looking up transform from frame [{source}] to frame [{target}]")
        if t < stamps[0]:
            raise ExtrapolationException(
                f"Lookup would require extrapolation into the past.  Requested time {_fmt(t)} but the earliest data "
                f"is at time {_fmt(stamps[0])}, when looking up transform from frame [{source}] to frame [{target}]")
        i = bisect.bisect_left(stamps, t)
        if stamps[i] == t:
            return edge.values[i]
        t0, t1 = stamps[i - 1], stamps[i]
        return interpolate(edge.values[i - 1], edge.values[i], (t - t0) / (t1 - t0))

    def _lookup_now(self, target: str, source: str, t: int):
        """(transform target<-source, stamp used) or raise; caller holds the lock."""
        for frame, arg in ((target, "target_frame"), (source, "source_frame")):
            if not frame:
                raise InvalidArgumentException(f"Invalid argument passed to lookupTransform argument {arg} in tf2 "
                                               "frame_ids cannot be empty")
            if not self._known(frame):
                raise LookupException(f'"{frame}" passed to lookupTransform argument {arg} does not exist. ')
        if target == source:
            return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0), t
        up_source, up_target = self._chain(source), self._chain(target)
        common = next((f for f in up_source if f in set(up_target)), None)
        if common is None:
            raise ConnectivityException(
                f"Could not find a connection between '{target}' and '{source}' because they are not part of the "
                "same tree.Tf has two or more unconnected trees.")
        path_source = up_source[:up_source.index(common)]
        path_target = up_target[:up_target.index(common)]
        if t == 0:  # latest time common to every dynamic edge of the chain
            latest = [self._edges[c].stamps[-1] for c in path_source + path_target if not self._edges[c].static]
            t = min(latest) if latest else 0
        root_source = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        for child in reversed(path_source):
            root_source = compose(root_source, self._edge_at(child, t, target, source))
        root_target = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        for child in reversed(path_target):
            root_target = compose(root_target, self._edge_at(child, t, target, source))
        return compose(inverse(root_target), root_source), t

    def lookup_transform(self, target_frame: str, source_frame: str, time: Time,
                         timeout: Duration | None = None) -> TransformStamped:
        """The transform that maps data in source_frame into target_frame at time (Time() = latest)."""
        target, source = strip_frame(target_frame), strip_frame(source_frame)
        t = _stamp_ns(time)
        wait_s = (timeout.nanoseconds / 1e9) if timeout is not None else 0.0
        with self._cond:
            if wait_s > 0:
                self._cond.wait_for(lambda: self._try(target, source, t) is None, timeout=wait_s)
            value, used = self._lookup_now(target, source, t)
        msg = TransformStamped()
        msg.header.frame_id = target
        msg.header.stamp = Time(nanoseconds=used).to_msg()
        msg.child_frame_id = source
        msg.transform.translation.x, msg.transform.translation.y, msg.transform.translation.z = value[:3]
        r = msg.transform.rotation
        r.x, r.y, r.z, r.w = value[3:]
        return msg

    def _try(self, target: str, source: str, t: int) -> TransformException | None:
        try:
            self._lookup_now(target, source, t)
            return None
        except TransformException as err:
            return err

    def can_transform(self, target_frame: str, source_frame: str, time: Time, timeout: Duration | None = None,
                      return_debug_tuple: bool = False):
        try:
            self.lookup_transform(target_frame, source_frame, time, timeout)
        except TransformException as err:
            return (False, str(err)) if return_debug_tuple else False
        return (True, "") if return_debug_tuple else True

    def transform_pose(self, pose: PoseStamped, target_frame: str, timeout: Duration | None = None,
                       latest: bool = False) -> PoseStamped:
        """tf2_geometry_msgs' do_transform_pose on a lookup at the pose's stamp (or the latest data)."""
        stamp = Time() if latest else Time.from_msg(pose.header.stamp)
        tf = self.lookup_transform(target_frame, pose.header.frame_id, stamp, timeout)
        p, o = pose.pose.position, pose.pose.orientation
        value = compose(_to_tuple(tf), (p.x, p.y, p.z, o.x, o.y, o.z, o.w))
        out = PoseStamped()
        out.header.frame_id = strip_frame(target_frame)
        out.header.stamp = pose.header.stamp
        out.pose.position.x, out.pose.position.y, out.pose.position.z = value[:3]
        q = out.pose.orientation
        q.x, q.y, q.z, q.w = value[3:]
        return out


class TransformListener:
    """Fills a Buffer from /tf and /tf_static."""

    def __init__(self, buffer: Buffer, node: Node, qos: QoSProfile = TF_QOS,
                 static_qos: QoSProfile = TF_STATIC_LISTENER_QOS):
        self.buffer = buffer
        self.node = node
        self._subs = [node.create_subscription(TFMessage, "/tf", self._on_tf, qos),
                      node.create_subscription(TFMessage, "/tf_static", self._on_tf_static, static_qos)]

    def _on_tf(self, msg: TFMessage) -> None:
        for tf in msg.transforms:
            self.buffer.set_transform(tf, "/tf")

    def _on_tf_static(self, msg: TFMessage) -> None:
        for tf in msg.transforms:
            self.buffer.set_transform_static(tf, "/tf_static")

    def unregister(self) -> None:
        for sub in self._subs:
            self.node.destroy_subscription(sub)
        self._subs = []


class TransformBroadcaster:
    def __init__(self, node: Node, qos: QoSProfile = TF_QOS):
        self._pub = create_publisher(node, TFMessage, "/tf", qos)

    def send_transform(self, transform: TransformStamped | list[TransformStamped]) -> None:
        self._pub.publish(TFMessage(transforms=list(transform) if isinstance(transform, list) else [transform]))


class StaticTransformBroadcaster:
    """Latched /tf_static: every send republishes all static transforms sent so far, by child frame."""

    def __init__(self, node: Node, qos: QoSProfile = TF_STATIC_QOS):
        self._pub = create_publisher(node, TFMessage, "/tf_static", qos)
        self._by_child: dict[str, TransformStamped] = {}

    def send_transform(self, transform: TransformStamped | list[TransformStamped]) -> None:
        for tf in (transform if isinstance(transform, list) else [transform]):
            self._by_child[tf.child_frame_id] = tf
        self._pub.publish(TFMessage(transforms=list(self._by_child.values())))
