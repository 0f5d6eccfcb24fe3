"""``NAME=VALUE`` overrides and run-time changes, checked like the parameter files.

Names are ROS 2 style, dotted below the node (``TebLocalPlannerROS.max_vel_x``,
``local_costmap.inflation_layer.inflation_radius``). A ``ParameterTable`` maps every name a node
declares to its spec; it is built from the node's parameter tree by the node's owner (for move_base,
move_base/parameter_tree.py), which also gives the whole-tree check that runs after the change, so
relations between parameters (max_samples >= min_samples) are checked too. Unlike a key in a file,
an unknown name here is an error: the user asked for it by name, as ``ros2 param set`` would fail.
"""

from __future__ import annotations

import copy
import difflib
from typing import Any, Callable

import yaml

from simplebot_navigation.parameters.spec import Param, ParameterError

ParameterTable = dict[str, Param]


def parse_assignment(text: str) -> tuple[str, Any]:
    """'a.b=0.6' -> ('a.b', 0.6); the value is read as a YAML scalar or list, as in a parameter file."""
    name, sep, raw = text.partition("=")
    name = name.strip()
    if not sep or not name or any(not part for part in name.split(".")):
        raise ParameterError(f"override {text!r}: expected NAME=VALUE with a dotted NAME such as "
                             "TebLocalPlannerROS.max_vel_x=0.6")
    try:
        value = yaml.safe_load(raw)
    except yaml.YAMLError as err:
        raise ParameterError(f"override {text!r}: the value is not valid YAML ({err})") from None
    if value is None:
        raise ParameterError(f"override {text!r}: the value is empty")
    return name, value


def lookup(table: ParameterTable, name: str) -> Param:
    """The spec of ``name``, or of the dict-valued parameter it lies under (footprint_model.radius);
    ParameterError naming the closest declared name when there is none."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        spec = table.get(".".join(parts[:end]))
        if spec is not None and (end == len(parts) or spec.kind is dict):
            return spec
    close = difflib.get_close_matches(name, list(table), n=1, cutoff=0.6)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    raise ParameterError(f"{name}: no such parameter{hint}")


def set_in_tree(tree: dict, name: str, value: Any, separator: str = ".") -> None:
    """Set a name (dotted, or ``separator``-joined) in a nested ROS 1 tree, creating namespaces on the way;
    a value where a namespace must go gives way to it."""
    *parents, leaf = name.split(separator)
    node = tree
    for part in parents:
        child = node.get(part)
        if not isinstance(child, dict):
            child = node[part] = {}
        node = child
    node[leaf] = value


def refuse_live_change(spec: Param, name: str, value: Any) -> None:
    """ParameterError when ``name`` must not change while the node runs: it is read only at start-up
    (restart-only in its spec), or it is accepted but has no effect here, so a change would do nothing."""
    if not spec.dynamic:
        raise ParameterError(f"{name}: requires restart (it is read only when the node starts); "
                             f"not set to {value!r}")
    if not spec.implemented:
        raise ParameterError(f"{name}: not set to {value!r}, since it has no effect here: {spec.reason}")


def apply_overrides(tree: dict, assignments, table: Callable[[dict], ParameterTable],
                    check_tree: Callable[[dict], list[str]], live: bool = False) -> tuple[dict, list[str]]:
    """A copy of ``tree`` with every ``NAME=VALUE`` (or (name, value) pair) applied, and the warnings of
    the whole-tree check. Raises ParameterError naming the override on an unknown name, a bad value,
    or (``live``) a parameter that cannot change while the node runs (refuse_live_change)."""
    result = copy.deepcopy(tree)
    for item in assignments:
        name, value = parse_assignment(item) if isinstance(item, str) else item
        names = table(result)
        spec = lookup(names, name)
        if live:
            refuse_live_change(spec, name, value)
        if name in names:                 # below a dict-valued parameter, check_tree judges the value
            value = spec.check(value, name)
        set_in_tree(result, name, value)
    return result, check_tree(result)
