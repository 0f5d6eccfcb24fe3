"""The ROS 1 parameter tree <-> flat ROS 2 parameters.

Namespaces become dotted names; a list of {name, type} entries (costmap plugins, recovery
behaviours) becomes the list of names plus ``<name>.plugin``; a nested or empty list becomes its
string form, as ROS 2 parameters hold only flat arrays of one type.
"""

from __future__ import annotations

import math
from typing import Any

from simplebot_navigation.parameters.overrides import set_in_tree
from simplebot_navigation.parameters.spec import ParameterError


def _array_value(key: str, values: list) -> list:
    kinds = {type(v) for v in values}
    if kinds == {bool}:
        return values
    if kinds <= {int, float} and bool not in kinds:
        if kinds == {int}:
            return values
        return [float(v) for v in values]
    if kinds == {str}:
        return values
    raise ParameterError(f"{key}: a list must hold values of one type (bool, number or string), got "
                     f"{sorted(k.__name__ for k in kinds)}")


def _format_nested_list(value: list) -> str:
    def fmt(item):
        if isinstance(item, list):
            return "[" + ", ".join(fmt(i) for i in item) + "]"
        return repr(item) if isinstance(item, str) else str(item)
    return fmt(value)


def to_ros2_overrides(tree: dict, where: str = "") -> dict[str, Any]:
    """Map a ROS 1 subtree to flat ROS 2 parameters (see the module docstring)."""
    out: dict[str, Any] = {}

    def put(name: str, value: Any) -> None:
        if isinstance(value, float) and not math.isfinite(value):
            raise ParameterError(f"{where}{name}: {value} is not a finite number")
        out[name] = value

    def walk(node: dict, prefix: str) -> None:
        for key, value in node.items():
            name = f"{prefix}{key}"
            if isinstance(value, dict):
                walk(value, name + ".")
            elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
                names = []
                for i, entry in enumerate(value):
                    if "name" not in entry or "type" not in entry:
                        raise ParameterError(f"{where}{name}[{i}]: plugin entries need 'name' and 'type', got {entry}")
                    names.append(str(entry["name"]))
                    for sub_key, sub_value in entry.items():
                        if sub_key == "name":
                            continue
                        put(f"{prefix}{entry['name']}.{'plugin' if sub_key == 'type' else sub_key}", sub_value)
                put(name, names)
            elif isinstance(value, list) and (not value or any(isinstance(v, (list, dict)) for v in value)):
                put(name, _format_nested_list(value))
            elif isinstance(value, list):
                put(name, _array_value(f"{where}{name}", value))
            else:
                put(name, value)

    walk(tree, "")
    return out


def from_ros2_overrides(params: dict[str, Any]) -> dict:
    """Rebuild the ROS 1 tree a node was given: dotted names nest, plugin lists come back as [{name, type}]."""
    tree: dict = {}
    for name, value in params.items():
        set_in_tree(tree, name, list(value) if isinstance(value, (list, tuple)) else value)

    def restore(node: dict) -> None:
        for key, value in list(node.items()):
            if isinstance(value, dict):
                restore(value)
            elif (isinstance(value, list) and value and all(isinstance(v, str) for v in value)
                  and all(isinstance(node.get(v), dict) and "plugin" in node[v] for v in value)):
                node[key] = [{"name": v, "type": node[v]["plugin"]} for v in value]
    restore(tree)
    return tree
