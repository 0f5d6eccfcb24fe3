"""move_base's parameters while it runs: what ``ros2 param set`` accepts takes effect, and what it refuses
it refuses with the reason; ``ros2 param describe`` gives each parameter its description and range.

A collaborator of MoveBaseNode (``MoveBaseLiveParameters(node)``). The checks and the configurations come from
move_base/live_parameters.py (no rclpy); this shell converts ROS 2 parameters, answers the set request at once,
and applies an accepted change at the start of the next control cycle (``apply_pending``), on the executor's
thread: TEB, the costmaps and their layers, the global planner and the recoveries take their new
configurations, Nav2's behaviours requested from then on their new limits, and the control, update and publish
timers their new periods. ``declare_behavior_server`` gives the node those limits at start-up.
"""

from __future__ import annotations

import array
import threading
from typing import Protocol

from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter

from simplebot_navigation.move_base.behaviors import BehaviorServerParams
from simplebot_navigation.move_base.live_parameters import (GLOBAL_PLANNER, LOCAL_PLANNER, MOVE_BASE,
                                                            LiveParameters, update_move_base_config)
from simplebot_navigation.move_base.parameter_tree import BEHAVIOR_SERVER, OBSTACLE_TRACKING
from simplebot_navigation.parameters import ParameterError, fields_of
from simplebot_navigation.ros.params import (NODE_LEVEL, declare_defaults, describe_declared, given_parameter_tree,
                                             refuse_unknown_parameters)


def _ours(name: str) -> bool:
    return name not in NODE_LEVEL and not name.startswith("qos_overrides.")


def ros1_value(value):
    """A ROS 2 parameter value as the ROS 1 tree holds it (arrays as lists)."""
    return list(value) if isinstance(value, (array.array, tuple)) else value


def _changes(params: list[Parameter]) -> list[tuple]:
    return [(param.name, ros1_value(param.value)) for param in params if _ours(param.name)]


def declare_behavior_server(node) -> BehaviorServerParams:
    """The limits of Nav2's behaviours (``behavior_server.*``) the node starts with, declared as they are used."""
    params = BehaviorServerParams.from_params(given_parameter_tree(node, BEHAVIOR_SERVER),
                                              f"move_base/{BEHAVIOR_SERVER}")
    for warning in params.warnings:
        node.get_logger().warn(warning)
    specs = fields_of(BehaviorServerParams)
    declare_defaults(node, {name: getattr(params, name) for name in specs}, prefix=BEHAVIOR_SERVER, specs=specs)
    return params


class LiveParameterHost(Protocol):
    """What MoveBaseLiveParameters changes: a rclpy Node (its parameters and logger) with these parts."""
    cfg: object                 # MoveBaseConfig
    global_costmap: object      # Costmap2DROS
    local_costmap: object
    planner: object             # GlobalPlannerPlugin
    controller: object          # LocalPlannerPlugin
    recovery_instances: dict    # behaviour name -> Recovery
    obstacle_tracking: object   # ObstacleTracking (ros/move_base/obstacle_tracking.py)
    external_obstacles: object  # ExternalObstacles (ros/move_base/external_obstacles.py)
    behavior_server: object     # BehaviorServerParams: what Nav2's behaviours requested from now on run with

    def set_controller_frequency(self, hz: float) -> None:
        """The control timer and its statistics follow the new rate (the controller is told here)."""


class MoveBaseLiveParameters:
    """Run-time parameter changes of a move_base node (dynamic_reconfigure semantics). Built after every part
    has declared its parameters: it describes those the launcher gave, then takes every change through the
    parameter layer's checks."""

    def __init__(self, node: LiveParameterHost):
        self.node = node
        self._live = LiveParameters(given_parameter_tree(node))
        self._live_lock = threading.Lock()   # a set request may come from another thread than the cycle
        describe_declared(node, self._live.table)
        self._prepared = None
        refuse_unknown_parameters(node)
        node.add_pre_set_parameters_callback(self._normalize_parameters)
        node.add_on_set_parameters_callback(self._on_set_parameters)
        node.add_post_set_parameters_callback(self._on_parameters_set)

    @property
    def table(self):
        """Every parameter a running node takes, by ROS 2 name, with its spec."""
        return self._live.table

    def _normalize_parameters(self, params: list[Parameter]) -> list[Parameter]:
        """Store what the node runs with: 1 for a float parameter becomes 1.0 (ROS 1 read it as 1.0)."""
        out = []
        with self._live_lock:
            for param in params:
                value = ros1_value(param.value)
                try:
                    normal = self._live.normalized(param.name, value) if _ours(param.name) else value
                except Exception:  # noqa: BLE001 - the checks of _on_set_parameters say what is wrong with it
                    normal = value
                same = type(normal) is type(value) and normal == value
                out.append(param if same else Parameter(param.name, value=normal))
        return out

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Accept or refuse a change as a whole, with the reason; it is kept once rclpy has stored it. Any
        exception in the checks is a refusal that says what failed: the caller always gets an answer, and the
        node keeps running with what it had."""
        changes = _changes(params)
        if not changes:
            return SetParametersResult(successful=True)
        with self._live_lock:
            try:
                self._prepared = self._live.prepare(changes)
            except Exception as err:  # noqa: BLE001 - see the docstring
                reason = str(err) if isinstance(err, ParameterError) else f"{type(err).__name__}: {err}"
                self.node.get_logger().warn(f"parameter change refused: {reason}")
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _on_parameters_set(self, params: list[Parameter]) -> None:
        """The parameters are stored (every on-set callback accepted them): the next control cycle takes them."""
        changes = _changes(params)
        if not changes:
            return
        with self._live_lock:
            prepared, self._prepared = self._prepared, None
            try:
                warnings = self._live.commit(prepared if prepared is not None and prepared.assignments == changes
                                             else self._live.prepare(changes))
            except Exception as err:  # noqa: BLE001 - only if another thread's change got in between: say so
                self.node.get_logger().error(f"parameter change stored but not applied: {err}")
                return
        for warning in warnings:
            self.node.get_logger().warn(warning)

    def apply_pending(self) -> None:
        """At the start of a control cycle: the changes accepted since the last one take effect."""
        with self._live_lock:
            change = self._live.take()
        if change is None:
            return
        try:
            self._apply(change)
        except Exception as err:  # noqa: BLE001 - a failed reconfiguration must not end the control loop
            self.node.get_logger().error(f"parameter change not fully applied ({change.describe()}): "
                                    f"{type(err).__name__}: {err}")
            return
        self.node.get_logger().info(f"parameters changed: {change.describe()}")

    def _apply(self, change) -> None:
        node, configs, parts = self.node, change.configs, change.parts
        if MOVE_BASE in parts and "controller_frequency" in update_move_base_config(node.cfg, configs.move_base):
            node.set_controller_frequency(node.cfg.controller_frequency)
        for costmap in (node.global_costmap, node.local_costmap):
            if costmap.name not in parts:
                continue
            changed = costmap.reconfigure(configs.costmaps[costmap.name])
            if "footprint" in changed and costmap is node.local_costmap:
                node.controller.set_costmap_footprint(costmap.footprint)
        if GLOBAL_PLANNER in parts:
            node.planner.reconfigure(configs.global_planner)
        if LOCAL_PLANNER in parts:
            node.controller.reconfigure(configs.local_planner)
        if OBSTACLE_TRACKING in parts:
            node.obstacle_tracking.reconfigure(configs.obstacle_tracking)
            node.external_obstacles.timeout = configs.obstacle_tracking.external_timeout
        if BEHAVIOR_SERVER in parts:
            node.behavior_server = configs.behavior_server
        for name, recovery in node.recovery_instances.items():
            if name in parts:
                for warning in recovery.configure(configs.recoveries[name]):
                    node.get_logger().warn(warning)
