"""Recorder: a node that records every topic to MCAP, as `ros2 bag record -a -s mcap` would.

Messages are written as they arrive on the wire (serialized CDR, no decoding), with
the ros2msg schemas rosbag2 writes, so Foxglove, `ros2 bag info/play` and the
`mcap` readers understand the file. Hidden topics (a name part starting with `_`,
such as action internals) are left out, as rosbag2 does by default. The launcher runs it with
--record, or `python -m simplebot_navigation.launch.record run.mcap` joins a running system.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
import time
from pathlib import Path

import yaml
from mcap.writer import CompressionType, Writer
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
              "int64", "uint64", "string", "wstring"}
SEPARATOR = "=" * 80
# rosbag2 writes an infinite QoS duration as this pair
_INFINITE_NS = 2**63 - 1
_INFINITE_SEC, _INFINITE_NSEC = 2147483647, 4294967295


# -- schemas ----------------------------------------------------------------------------------------
def _interface_dirs() -> list[Path]:
    """share/ folders that hold .msg files: this environment's, then those of a sourced ROS 2 install."""
    prefixes = [sys.prefix, *filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep))]
    return [Path(p) / "share" for p in prefixes]


def _msg_text(type_name: str) -> str:
    package, _, name = type_name.partition("/msg/")
    for share in _interface_dirs():
        path = share / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path.read_text(encoding="utf-8")
    raise FileNotFoundError(f"no definition {package}/msg/{name}.msg in "
                            + ", ".join(str(d) for d in _interface_dirs()))


def _field_types(text: str, package: str) -> list[str]:
    """Complex field types of a .msg text as pkg/msg/Name (constants and primitives left out)."""
    types = []
    for line in text.splitlines():
        words = line.split("#", 1)[0].split()
        if len(words) < 2 or "=" in words[1] or "=" in words[0]:
            continue
        base = re.sub(r"\[.*\]$", "", words[0]).split("<=")[0]
        if base in PRIMITIVES:
            continue
        parts = base.split("/")
        types.append(f"{parts[0]}/msg/{parts[-1]}" if len(parts) > 1 else f"{package}/msg/{base}")
    return types


def message_definition(type_name: str) -> str:
    """The ros2msg schema of a message type: its .msg text, then every type it uses, each once."""
    if "/msg/" not in type_name:
        raise ValueError(f"{type_name!r} is not a message type (pkg/msg/Name)")
    top = _msg_text(type_name)
    parts, seen = [top], {type_name}
    pending = _field_types(top, type_name.split("/")[0])
    while pending:
        dep = pending.pop(0)
        if dep in seen:
            continue
        seen.add(dep)
        text = _msg_text(dep)
        parts.append(f"{SEPARATOR}\nMSG: {dep}\n{text}")
        pending.extend(_field_types(text, dep.split("/")[0]))
    return "\n".join(p.rstrip("\n") for p in parts) + "\n"


def _hidden(topic: str) -> bool:
    return any(part.startswith("_") for part in topic.split("/"))


# -- recording --------------------------------------------------------------------------------------
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
        self._skipped: set[str] = set()
        try:
            self._stream = open(path, "wb")  # noqa: SIM115 - closed in close()
        except OSError as err:
            self.destroy_node()
            raise ValueError(f"recorder cannot write {path}: {err.strerror}") from err
        self.writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self.writer.start(profile="ros2", library="simplebot_navigation")
        self.discover()
        self.create_timer(period, self.discover)
        self.get_logger().info(f"recording every topic to {path}")

    def _qos(self, topic: str) -> QoSProfile:
        """Match the publishers: latched if they all are (to get their last message), best effort if any is."""
        infos = self.get_publishers_info_by_topic(topic)
        latched = bool(infos) and all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
        best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
        return QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                          else ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)

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
        for topic, types in self.get_topic_names_and_types():
            # A topic only subscribers know of yet waits: its QoS comes from the publishers.
            if topic in self.counts or topic in self._skipped or _hidden(topic) or not self.count_publishers(topic):
                continue
            if len(types) != 1:
                self._skip(topic, f"it has more than one type ({', '.join(types)})")
                continue
            type_name = types[0]
            try:
                package, _, name = type_name.partition("/msg/")
                msg_class = getattr(importlib.import_module(f"{package}.msg"), name)
                if type_name not in self._schemas:
                    self._schemas[type_name] = self.writer.register_schema(
                        type_name, "ros2msg", message_definition(type_name).encode("utf-8"))
            except (ImportError, AttributeError, FileNotFoundError, ValueError) as err:
                self._skip(topic, f"type {type_name} is not available here: {err}")
                continue
            channel = self.writer.register_channel(topic, "cdr", self._schemas[type_name],
                                                   {"offered_qos_profiles": self._offered_qos(topic)})
            self.counts[topic] = 0
            self.create_subscription(msg_class, topic, lambda data, t=topic, c=channel: self._write(t, c, data),
                                     self._qos(topic), raw=True)

    def _skip(self, topic: str, why: str) -> None:
        self._skipped.add(topic)
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
