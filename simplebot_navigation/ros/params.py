"""ROS 2 parameters <-> the ROS 1 parameter tree the pure modules understand (DESIGN §4).

Nodes are created with ``automatically_declare_parameters_from_overrides``, so
what the launcher gave them is declared with the given types; the pure modules
resolve defaults on the ROS 1 tree, and ``declare_defaults`` then declares the
rest with their ROS 1 defaults so that ``ros2 param list`` tells the truth.
"""

from __future__ import annotations

import math
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from simplebot_navigation.launch.rosparam import from_ros2_overrides, to_ros2_overrides

_NODE_LEVEL = {"use_sim_time", "start_type_description_service"}


def given_parameter_tree(node: Node, prefix: str = "") -> dict:
    """The ROS 1 tree of the parameters this node was started with, below prefix ('' = all)."""
    values = {name: param.value for name, param in node.get_parameters_by_prefix(prefix).items()
              if prefix or name not in _NODE_LEVEL}
    return from_ros2_overrides(values)


def declare_defaults(node: Node, defaults: dict[str, Any], prefix: str = "") -> None:
    """Declare every leaf of a resolved ROS 1 tree that the node does not have yet."""
    flat = to_ros2_overrides(defaults, where=node.get_fully_qualified_name() + "/")
    for name, value in flat.items():
        full = f"{prefix}.{name}" if prefix else name
        if not node.has_parameter(full) and value is not None:
            node.declare_parameter(full, value)


def declare_checked(node: Node, defaults: dict[str, Any], label: str = "parameter",
                    positive: tuple[str, ...] = ()) -> dict[str, Any]:
    """Declare a node's own parameters and check their types (an int where a float is expected is fine),
    before anything else is built; names in ``positive`` must be finite rates > 0 (Hz)."""
    values = {}
    for name, default in defaults.items():
        value = node.declare_parameter(name, default, ParameterDescriptor(dynamic_typing=True)).value
        if isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if type(value) is not type(default):
            raise ValueError(f"{label} {name!r} must be a {type(default).__name__}, got {value!r}")
        values[name] = value
    for name in positive:
        if not (math.isfinite(values[name]) and values[name] > 0):
            raise ValueError(f"{label} {name!r} must be a positive number of Hz, got {values[name]!r}")
    return values
