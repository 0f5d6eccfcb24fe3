"""ROS 2 parameters <-> the ROS 1 parameter tree the pure modules understand (docs/design.md §4).

Nodes are created with ``automatically_declare_parameters_from_overrides``, so
what the launcher gave them is declared with the given types; the pure modules
resolve defaults on the ROS 1 tree, and ``declare_defaults`` then declares the
rest with their ROS 1 defaults, each with the description and range of its spec
(``describe_declared`` gives them to the given ones afterwards), so that ``ros2 param list``
and ``ros2 param describe`` tell the truth.
"""

from __future__ import annotations

import difflib
import math
from typing import Any, Callable

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.node import Node
from rclpy.parameter import Parameter

from simplebot_navigation.parameters import Param, ParameterError
from simplebot_navigation.parameters.overrides import lookup
from simplebot_navigation.parameters.ros2 import from_ros2_overrides, to_ros2_overrides

#: parameters rclpy gives every node itself: not part of any ROS 1 tree
NODE_LEVEL = frozenset({"use_sim_time", "start_type_description_service"})
_INT64 = 2 ** 63 - 1


def given_parameter_tree(node: Node, prefix: str = "") -> dict:
    """The ROS 1 tree of the parameters this node was started with, below prefix ('' = all)."""
    values = {name: param.value for name, param in node.get_parameters_by_prefix(prefix).items()
              if prefix or name not in NODE_LEVEL}
    return from_ros2_overrides(values)


def descriptor(spec: Param | None) -> ParameterDescriptor:
    """The description and range of a declared parameter (ROS 2 ranges are closed: '> 0' shows as from 0;
    the parameter layer still rejects 0; an open end shows as inf, which the layer rejects too). Typing is
    dynamic: the spec judges a value's type when it is set (an int is fine for a float), with a reason
    naming the parameter and the value."""
    if spec is None:
        return ParameterDescriptor()
    out = ParameterDescriptor(description=spec.describe(), read_only=False, dynamic_typing=True)
    if spec.low is None and spec.high is None:
        return out
    if spec.kind is float:
        big = math.inf
        out.floating_point_range = [FloatingPointRange(
            from_value=-big if spec.low is None else float(spec.low),
            to_value=big if spec.high is None else float(spec.high), step=0.0)]
    elif spec.kind is int:
        out.integer_range = [IntegerRange(from_value=-_INT64 if spec.low is None else int(spec.low),
                                          to_value=_INT64 if spec.high is None else int(spec.high), step=1)]
    return out


def declare_defaults(node: Node, defaults: dict[str, Any], prefix: str = "",
                     specs: dict[str, Param] | None = None) -> None:
    """Declare every leaf of a resolved ROS 1 tree that the node does not have yet; ``specs`` (by the
    leaf's dotted name below prefix) give the descriptions and ranges."""
    flat = to_ros2_overrides(defaults, where=node.get_fully_qualified_name() + "/")
    for name, value in flat.items():
        full = f"{prefix}.{name}" if prefix else name
        if not node.has_parameter(full) and value is not None:
            node.declare_parameter(full, value, descriptor((specs or {}).get(name)))


def describe_declared(node: Node, table: dict[str, Param]) -> None:
    """Give every declared parameter in ``table`` (by ROS 2 name) the description and range of its spec:
    the parameters the launcher gave were declared from the overrides, without either. A whole number
    given for a float parameter becomes a float (and 30.0 for an int 30), as the node runs with it."""
    for name, param in node.get_parameters_by_prefix("").items():
        try:
            spec = lookup(table, name)
        except ParameterError:
            continue                     # node-level (use_sim_time) or not ours
        node.set_descriptor(name, descriptor(spec))
        if name in table and spec.kind in (int, float) and not isinstance(param.value, bool):
            value = spec.check(param.value, name)
            if type(value) is not type(param.value):
                node.set_parameters([Parameter(name, value=value)])


def declare_checked(node: Node, defaults: dict[str, Any], label: str = "parameter",
                    positive: tuple[str, ...] = ()) -> dict[str, Any]:
    """Declare a node's own parameters and check them with the parameter layer's rules (the default's
    type, an int where a float is expected is fine, no NaN or inf), before anything else is built;
    names in ``positive`` are rates in Hz that must be > 0."""
    values = {}
    for name, default in defaults.items():
        value = node.declare_parameter(name, default, ParameterDescriptor(dynamic_typing=True)).value
        rate = name in positive
        spec = Param(type(default), default, "Hz" if rate else "", name, low=0.0 if rate else None, low_open=rate)
        values[name] = spec.check(value, f"{label} {name!r}")
    return values


def declare_specs(node: Node, specs: dict[str, Param], label: str) -> dict[str, Any]:
    """Declare a node's own parameters from their specs and check each (type, range) before anything is built;
    ParameterError names the parameter and the value. The descriptors then carry each spec's description and
    range, for ``ros2 param describe``."""
    values = {}
    for name, spec in specs.items():
        value = node.declare_parameter(name, spec.default, ParameterDescriptor(dynamic_typing=True)).value
        values[name] = spec.check(value, f"{label} {name!r}")
        node.set_descriptor(name, descriptor(spec))
    return values


def take_live_changes(node: Node, specs: dict[str, Param], label: str,
                      apply: Callable[[dict[str, Any]], None]) -> None:
    """Changes while running: a name the node does not have, one it reads at start-up only (``dynamic=False``) or a
    value its spec refuses is refused with the reason, and nothing changes; otherwise ``apply`` gets every change of
    the request, checked and converted (it may still refuse with ValueError)."""
    refuse_unknown_parameters(node)

    def on_set(params: list[Parameter]) -> SetParametersResult:
        ours = [p for p in params if p.name in specs]
        fixed = [p.name for p in ours if not specs[p.name].dynamic]
        if fixed:
            return SetParametersResult(successful=False, reason=f"{label} {', '.join(map(repr, fixed))}: requires "
                                                                "restart (read at start-up only)")
        try:
            changes = {p.name: specs[p.name].check(p.value, f"{label} {p.name!r}") for p in ours}
            if changes:
                apply(changes)
        except ValueError as err:
            return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)
    node.add_on_set_parameters_callback(on_set)


def refuse_unknown_parameters(node: Node) -> None:
    """Refuse a set request for a name the node does not have, naming it and the closest one it has: rclpy's own
    refusal says "undeclared parameter(s): []". (rclpy turns the exception into the request's failed result.)"""
    def check(params: list[Parameter]) -> list[Parameter]:
        unknown = [param.name for param in params if not node.has_parameter(param.name)]
        if unknown:
            known = node.list_parameters([], 0).names
            raise ParameterNotDeclaredException("; ".join(
                f"'{name}' is not a parameter of {node.get_fully_qualified_name()}"
                + "".join(f" (did you mean '{match}'?)" for match in difflib.get_close_matches(name, known, n=1))
                for name in unknown))
        return params
    node.add_pre_set_parameters_callback(check)
