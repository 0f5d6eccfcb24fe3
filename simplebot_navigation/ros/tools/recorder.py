"""Recorder: a node that records every topic to MCAP, as `ros2 bag record -a -s mcap` would.

Messages are written as they arrive on the wire (serialized CDR, no decoding), with
the ros2msg schemas rosbag2 writes (ros/tools/raw_topics.py), so Foxglove, `ros2 bag info/play` and the
`mcap` readers understand the file. Hidden topics are left out, as rosbag2 does by default. The launcher runs it with
--record, or `python -m simplebot_navigation.launch.record run.mcap` joins a running system.
"""

from __future__ import annotations

import time

import yaml
from mcap.writer import CompressionType, Writer
from rclpy.node import Node

from simplebot_navigation.ros.tools.raw_topics import TopicDiscovery, publisher_qos

# rosbag2 writes an infinite QoS duration as this pair
_INFINITE_NS = 2**63 - 1
_INFINITE_SEC, _INFINITE_NSEC = 2147483647, 4294967295


class Recorder(Node):
    """Subscribes to each topic as it appears (every `discovery_period` s) and writes raw messages."""

    def __init__(self, path: str | None = None, **kwargs):
        super().__init__("recorder", **kwargs)
        self.writer = None
        path = self.declare_parameter("path", path or "").value
        period = self.declare_parameter("discovery_period", 0.5).value
        if not path:
            self.destroy_node()
            raise ValueError("recorder parameter 'path' (the .mcap file to write) is not set")
        if not (isinstance(period, (int, float)) and period > 0):
            self.destroy_node()
            raise ValueError(f"recorder parameter 'discovery_period' must be > 0 s, got {period!r}")
        self.path = path
        self.counts: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        try:
            self._stream = open(path, "wb")  # noqa: SIM115 - closed in close()
        except OSError as err:
            self.destroy_node()
            raise ValueError(f"recorder cannot write {path}: {err.strerror}") from err
        self.writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self.writer.start(profile="ros2", library="simplebot_navigation")
        self.discovery = TopicDiscovery(self, self._skip)
        self.discover()
        self.create_timer(period, self.discover)
        self.get_logger().info(f"recording every topic to {path}")

    def _offered_qos(self, topic: str) -> str:
        """rosbag2's ``offered_qos_profiles`` channel metadata, so that ``ros2 bag play`` republishes latched
        topics (/tf_static, /robot_description, the costmaps) latched."""
        def duration(d) -> dict:
            ns = d.nanoseconds
            if ns >= _INFINITE_NS:
                return {"sec": _INFINITE_SEC, "nsec": _INFINITE_NSEC}
            return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}

        profiles = [{"history": int(q.history), "depth": int(q.depth), "reliability": int(q.reliability),
                     "durability": int(q.durability), "deadline": duration(q.deadline),
                     "lifespan": duration(q.lifespan), "liveliness": int(q.liveliness),
                     "liveliness_lease_duration": duration(q.liveliness_lease_duration),
                     "avoid_ros_namespace_conventions": bool(q.avoid_ros_namespace_conventions)}
                    for q in (info.qos_profile for info in self.get_publishers_info_by_topic(topic))]
        return yaml.safe_dump(profiles, sort_keys=False)

    def discover(self) -> None:
        for topic in self.discovery.poll():
            if topic.type_name not in self._schemas:
                self._schemas[topic.type_name] = self.writer.register_schema(
                    topic.type_name, "ros2msg", topic.definition.encode("utf-8"))
            channel = self.writer.register_channel(topic.name, "cdr", self._schemas[topic.type_name],
                                                   {"offered_qos_profiles": self._offered_qos(topic.name)})
            self.counts[topic.name] = 0
            self.create_subscription(topic.msg_class, topic.name,
                                     lambda data, t=topic.name, c=channel: self._write(t, c, data),
                                     publisher_qos(self, topic.name), raw=True)

    def _skip(self, topic: str, why: str) -> None:
        self.get_logger().warn(f"not recording {topic}: {why}")

    def _write(self, topic: str, channel: int, data: bytes) -> None:
        now = time.time_ns()
        self.writer.add_message(channel, log_time=now, data=data, publish_time=now, sequence=self.counts[topic])
        self.counts[topic] += 1

    def close(self) -> None:
        """Finish the file (summary and index): without it, readers must scan the whole file."""
        if self.writer is None:
            return
        self.writer.finish()
        self._stream.close()
        self.writer = None
        total = sum(self.counts.values())
        self.get_logger().info(f"recorded {total} messages on {len(self.counts)} topics to {self.path}")

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()
