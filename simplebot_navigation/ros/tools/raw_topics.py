"""Every topic of the graph as raw CDR: discovery, the publishers' QoS, and the ros2msg schema of each type.

The MCAP recorder (ros/tools/recorder.py) and the Foxglove bridge (ros/tools/foxglove_bridge.py) both pass messages
on without decoding them, each labelled with the message definition rosbag2 and Foxglove read: the
type's .msg text, then every type it uses after a line of 80 ``=`` and ``MSG: pkg/msg/Name``.
Hidden topics (a name part starting with ``_``, such as action internals) are left out, as rosbag2
does by default.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
              "int64", "uint64", "string", "wstring"}
SEPARATOR = "=" * 80


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


def message_class(type_name: str) -> type:
    """The Python class of pkg/msg/Name; ImportError or AttributeError if this environment lacks it."""
    package, _, name = type_name.partition("/msg/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


# -- the graph --------------------------------------------------------------------------------------
def hidden(topic: str) -> bool:
    return any(part.startswith("_") for part in topic.split("/"))


def publisher_qos(node: Node, topic: str, depth: int = 100) -> QoSProfile:
    """Match the publishers: latched if they all are (to get their last message), best effort if any is."""
    infos = node.get_publishers_info_by_topic(topic)
    latched = bool(infos) and all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
    best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                      else ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


@dataclass(frozen=True)
class RawTopic:
    name: str
    type_name: str      # pkg/msg/Name
    msg_class: type     # what create_subscription(..., raw=True) needs for the type support
    definition: str     # the ros2msg schema


class TopicDiscovery:
    """Finds the graph's new topics, each once. A topic only subscribers know of yet waits (its QoS comes
    from the publishers); one that cannot be passed on (several types, a type missing here) is reported
    once through ``skip(topic, why)`` and then ignored."""

    def __init__(self, node: Node, skip: Callable[[str, str], None]):
        self.node = node
        self.skip = skip
        self.known: set[str] = set()
        self._definitions: dict[str, str] = {}

    def poll(self) -> list[RawTopic]:
        found = []
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self.known or hidden(topic) or not self.node.count_publishers(topic):
                continue
            self.known.add(topic)
            if len(types) != 1:
                self.skip(topic, f"it has more than one type ({', '.join(types)})")
                continue
            type_name = types[0]
            try:
                msg_class = message_class(type_name)
                if type_name not in self._definitions:
                    self._definitions[type_name] = message_definition(type_name)
            except (ImportError, AttributeError, FileNotFoundError, ValueError) as err:
                self.skip(topic, f"type {type_name} is not available here: {err}")
                continue
            found.append(RawTopic(topic, type_name, msg_class, self._definitions[type_name]))
        return found
