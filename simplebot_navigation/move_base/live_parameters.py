"""Parameter changes while move_base runs, with ROS 1's dynamic_reconfigure semantics (no rclpy).

The node keeps the ROS 1 tree it runs with. A change (ROS 2 names and values, as ``ros2 param set``
sends them) goes through the checks of ``--set`` with ``live=True`` (apply_move_base_overrides): a bad
value, an unknown name, a restart-only parameter or one without effect here raises ParameterError,
and nothing changes. An accepted change (``prepare``, then ``commit`` once the ROS side has stored it)
updates the tree and builds every configuration again from it; the node takes them at its next control
cycle (``take``), and each running object copies what may change from its own: MoveBaseConfig
(update_move_base_config), CostmapCore.reconfigure, TebLocalPlanner.reconfigure, a new GlobalPlanner, the
recoveries' configure, ObstacleTracker.reconfigure, the limits of Nav2's behaviours requested from then on, and
the node's timers.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from typing import Any, Iterable

import numpy as np

from simplebot_navigation.parameters import ParameterError, fields_of
from simplebot_navigation.parameters.overrides import ParameterTable, lookup, set_in_tree
from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.parameter_tree import (BEHAVIOR_SERVER, COSTMAPS, OBSTACLE_TRACKING, NodeConfigs,
                                                           apply_move_base_overrides, build_configs, crowd_planner,
                                                           live_parameter_table)
from simplebot_navigation.move_base.plugins import plugin_namespace

#: the parts of a node a change can reach, besides each costmap (by name) and each recovery (by name)
MOVE_BASE, GLOBAL_PLANNER, LOCAL_PLANNER, CROWD_PLANNER = "move_base", "global_planner", "local_planner", "crowd_planner"


@dataclass
class LiveChange:
    """The changes since the running objects last took one: what to apply at the next control cycle."""
    assignments: list[tuple[str, Any]] = field(default_factory=list)   # (ROS 2 name, value), in order
    parts: set[str] = field(default_factory=set)                      # the parts they reach
    configs: NodeConfigs | None = None                                 # every configuration after them

    def describe(self) -> str:
        return ", ".join(f"{name} = {value!r}" for name, value in self.assignments)


@dataclass
class PreparedChange:
    """A checked change, not yet kept: the tree it was checked against, and what it makes of it."""
    assignments: list[tuple[str, Any]]
    base: dict
    tree: dict
    configs: NodeConfigs
    warnings: list[str]


class LiveParameters:
    """The tree and configurations a running move_base has, and the changes it has yet to take."""

    def __init__(self, tree: dict):
        self.tree = copy.deepcopy(tree)
        self.configs = build_configs(self.tree)
        self.table: ParameterTable = live_parameter_table(self.tree)
        self._pending: LiveChange | None = None

    def change(self, assignments: Iterable[tuple[str, Any]]) -> list[str]:
        """Check (name, value) pairs as one change and keep it for the next take(). Raises ParameterError
        naming the parameter, the value and why; returns the warnings the change brings that were not
        there before (a parameter without effect, say)."""
        return self.commit(self.prepare(assignments))

    def prepare(self, assignments: Iterable[tuple[str, Any]]) -> PreparedChange:
        """The checks of change() without keeping anything (ParameterError when refused)."""
        assignments = list(assignments)
        tree, warnings = apply_move_base_overrides(self.tree, assignments, live=True)
        configs = build_configs(tree)
        for name, value in assignments:
            self._refuse_without_effect(name, value, tree, configs)
        before = set(self.configs.warnings)
        return PreparedChange(assignments, self.tree, tree, configs, [w for w in warnings if w not in before])

    def commit(self, prepared: PreparedChange) -> list[str]:
        """Keep a prepared change (checked again if another one was kept since); its new warnings."""
        if prepared.base is not self.tree:
            prepared = self.prepare(prepared.assignments)
        self.tree, self.configs = prepared.tree, prepared.configs
        pending = self._pending or LiveChange()
        pending.assignments += prepared.assignments
        pending.parts |= {self._part(name) for name, _ in prepared.assignments}
        if MOVE_BASE in pending.parts:                 # footprint, robot_radius, ... are searched upwards
            pending.parts |= set(COSTMAPS)
        pending.configs = prepared.configs
        self._pending = pending
        return prepared.warnings

    def take(self) -> LiveChange | None:
        """The changes accepted since the last call (None: none)."""
        pending, self._pending = self._pending, None
        return pending

    def normalized(self, name: str, value: Any) -> Any:
        """``value`` as the parameter holds it (1 -> 1.0 for a float, 2.6 -> 3 for a rounded int), so the
        node stores what it runs with; unchanged when it does not fit, for change() to say why."""
        spec = self.table.get(name)
        if spec is None or spec.kind not in (int, float) or isinstance(value, bool):
            return value
        try:
            return spec.check(value, name)
        except ParameterError:
            return value

    def _refuse_without_effect(self, name: str, value: Any, tree: dict, configs: NodeConfigs) -> None:
        """ParameterError when a new value changes no configuration: another parameter takes precedence
        (a footprint over robot_radius, a costmap-level key over its layer's, a nearer namespace over a
        farther one for searched keys), so accepting it would leave the server saying what is not so."""
        old, new = _leaf(self.tree, name), _leaf(tree, name)
        if old == new or (old is _MISSING and new == lookup(self.table, name).default):
            return                                      # the value it has: nothing to do
        without = copy.deepcopy(tree)
        if old is _MISSING:
            parent, _, leaf = name.rpartition(".")
            (_leaf(without, parent) if parent else without).pop(leaf, None)
        else:
            set_in_tree(without, name, old)
        try:
            unchanged = _same(build_configs(without), configs)
        except ParameterError:          # the rest of the change needs this value (static_speed < moving_speed)
            return
        if unchanged:
            raise ParameterError(f"{name}: not set to {value!r}, since it has no effect here: another parameter "
                                 "takes precedence (a footprint over robot_radius, a costmap-level key over its "
                                 "layer's, a nearer namespace over a farther one)")

    def _part(self, name: str) -> str:
        first = name.split(".")[0]
        if first in COSTMAPS or first in self.configs.recoveries or first in (OBSTACLE_TRACKING, BEHAVIOR_SERVER):
            return first
        cfg = self.configs.move_base
        if first == plugin_namespace(cfg.base_global_planner):
            return GLOBAL_PLANNER
        if first == plugin_namespace(cfg.base_local_planner):
            return LOCAL_PLANNER
        if crowd_planner(cfg) and first == plugin_namespace(crowd_planner(cfg)):
            return CROWD_PLANNER
        return MOVE_BASE


def update_move_base_config(running: MoveBaseConfig, new: MoveBaseConfig) -> list[str]:
    """Copy what may change while running into the configuration the node and its state machine share
    (both read it every cycle); the names that changed."""
    changed = [name for name, spec in fields_of(MoveBaseConfig).items()
               if spec.dynamic and getattr(new, name) != getattr(running, name)]
    for name in changed:
        setattr(running, name, getattr(new, name))
    return changed


_MISSING = object()


def _leaf(tree: dict, name: str) -> Any:
    node: Any = tree
    for part in name.split("."):
        node = node.get(part, _MISSING) if isinstance(node, dict) else _MISSING
    return node


def _same(a: Any, b: Any) -> bool:
    """Equal configurations (dataclasses, dicts, lists, arrays), their warnings aside."""
    if dataclasses.is_dataclass(a) and type(a) is type(b):
        return all(_same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
                   if f.name != "warnings")
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[key], b[key]) for key in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return a == b
