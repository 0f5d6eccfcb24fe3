"""move_base's parameters while it runs: what ``ros2 param set`` accepts takes effect, and what it refuses
it refuses with the reason; ``ros2 param describe`` gives each parameter its description and range.

A part of MoveBaseNode, given the parts a change reaches, never the node. The checks and the configurations come from
move_base/live_parameters.py (no rclpy); this shell converts ROS 2 parameters, answers the set request at once,
and applies an accepted change at the start of the next control cycle (``apply_pending``), on the executor's
thread: TEB, the costmaps and their layers, the global planner and the recoveries take their new
configurations, Nav2's behaviours requested from then on their new limits, and the control, update and publish
timers their new periods.
"""

from __future__ import annotations

import array
import threading

from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter

from simplebot_navigation.move_base.live_parameters import (CROWD_PLANNER, GLOBAL_PLANNER, LOCAL_PLANNER, MOVE_BASE,
                                                            LiveParameters, update_move_base_config)
from simplebot_navigation.move_base.parameter_tree import BEHAVIOR_SERVER, OBSTACLE_TRACKING
from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.ros.params import NODE_LEVEL


def _ours(name: str) -> bool:
    return name not in NODE_LEVEL and not name.startswith("qos_overrides.")


def ros1_value(value):
    """A ROS 2 parameter value as the ROS 1 tree holds it (arrays as lists)."""
    return list(value) if isinstance(value, (array.array, tuple)) else value


def _changes(params: list[Parameter]) -> list[tuple]:
    return [(param.name, ros1_value(param.value)) for param in params if _ours(param.name)]


class MoveBaseLiveParameters:
    """Run-time parameter changes of a move_base node (dynamic_reconfigure semantics). Built after every part
    has declared its parameters, from the tree the launcher gave (``given``) and the parts a change reaches: the
    configuration ``cfg``, both costmaps, the global ``planner`` and the ``controller`` plugins, the recovery
    instances by name, obstacle ``tracking`` and ``external`` obstacles, ``set_controller_frequency(hz)`` for the
    node's timers and ``set_behavior_server(params)`` for Nav2's behaviours. The node hands its parameter callbacks to ``normalize``, ``check`` and ``stored``."""

    def __init__(self, given: dict, logger, *, cfg, global_costmap, local_costmap, planner, controller,
                 recoveries: dict, tracking, external, set_controller_frequency, set_behavior_server):
        self._log = logger
        self.cfg, self.costmaps = cfg, (global_costmap, local_costmap)
        self.local_costmap, self.planner, self.controller = local_costmap, planner, controller
        self.recoveries, self.tracking, self.external = recoveries, tracking, external
        self._set_controller_frequency = set_controller_frequency
        self._set_behavior_server = set_behavior_server
        self._live = LiveParameters(given)
        self._live_lock = threading.Lock()   # a set request may come from another thread than the cycle
        self._prepared = None

    @property
    def table(self):
        """Every parameter a running node takes, by ROS 2 name, with its spec."""
        return self._live.table

    def normalize(self, params: list[Parameter]) -> list[Parameter]:
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

    def check(self, params: list[Parameter]) -> SetParametersResult:
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
                self._log.warn(f"parameter change refused: {reason}")
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def stored(self, params: list[Parameter]) -> None:
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
                self._log.error(f"parameter change stored but not applied: {err}")
                return
        for warning in warnings:
            self._log.warn(warning)

    def apply_pending(self) -> None:
        """At the start of a control cycle: the changes accepted since the last one take effect."""
        with self._live_lock:
            change = self._live.take()
        if change is None:
            return
        try:
            self._apply(change)
        except Exception as err:  # noqa: BLE001 - a failed reconfiguration must not end the control loop
            self._log.error(f"parameter change not fully applied ({change.describe()}): "
                                    f"{type(err).__name__}: {err}")
            return
        self._log.info(f"parameters changed: {change.describe()}")

    def _apply(self, change) -> None:
        configs, parts = change.configs, change.parts
        if MOVE_BASE in parts and "controller_frequency" in update_move_base_config(self.cfg, configs.move_base):
            self._set_controller_frequency(self.cfg.controller_frequency)
        for costmap in self.costmaps:
            if costmap.name not in parts:
                continue
            changed = costmap.reconfigure(configs.costmaps[costmap.name])
            if "footprint" in changed and costmap is self.local_costmap:
                self.controller.set_costmap_footprint(costmap.footprint)
        if GLOBAL_PLANNER in parts:
            self.planner.reconfigure(configs.global_planner)
        if LOCAL_PLANNER in parts:
            self.controller.reconfigure(configs.local_planner)
        if CROWD_PLANNER in parts:
            self.controller.reconfigure_crowd(configs.crowd_planner)
        if OBSTACLE_TRACKING in parts:
            self.tracking.reconfigure(configs.obstacle_tracking)
            self.external.timeout = configs.obstacle_tracking.external_timeout
        if BEHAVIOR_SERVER in parts:
            self._set_behavior_server(configs.behavior_server)
        for name, recovery in self.recoveries.items():
            if name in parts:
                for warning in recovery.configure(configs.recoveries[name]):
                    self._log.warn(warning)
