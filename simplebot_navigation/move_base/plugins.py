"""move_base's plugins: each type (a ROS 1 pluginlib name) registered once, with its parameter class.

A registration names the implementation as ``"module:attribute"`` text, as pluginlib's XML names a class:
the ROS node loads it when a configuration selects the type, and everything below the ROS layer (the
parameter tree, ``--print-params``, live parameters, the "unknown type" message) reads the rest of the
registration without importing it. The interfaces an implementation must satisfy are documented where
they are used: ``GlobalPlannerPlugin`` and ``LocalPlannerPlugin`` below for the ROS wrappers, ``Recovery``
and ``RecoveryContext`` in move_base/recovery/, ``Layer`` in costmap/layer.py; docs/plugins.md shows how to
add one.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Callable, Protocol

import numpy as np

from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.parameters.registry import Registry
from simplebot_navigation.planning.config import GLOBAL_PLANNER, NAVFN, GlobalPlannerConfig, NavfnParams
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.move_base.recovery.backup import BackUpParams
from simplebot_navigation.move_base.recovery.clear_costmap import ClearCostmapParams
from simplebot_navigation.move_base.recovery.rotate import RotateParams
from simplebot_navigation.move_base.recovery.spin import SpinParams

TEB_LOCAL_PLANNER = "teb_local_planner/TebLocalPlannerROS"
CLEAR_COSTMAP_RECOVERY = "clear_costmap_recovery/ClearCostmapRecovery"
ROTATE_RECOVERY = "rotate_recovery/RotateRecovery"
# Nav2's BackUp and Spin behaviours as move_base recovery behaviours (move_base/recovery/).
BACKUP_RECOVERY = "backup_recovery/BackUpRecovery"
SPIN_RECOVERY = "spin_recovery/SpinRecovery"


def plugin_namespace(plugin_type: str) -> str:
    """A plugin's parameter namespace as ROS 1 move_base derives it: the class name after the '/'."""
    return plugin_type.rpartition("/")[2]


@dataclass(frozen=True)
class PluginSpec:
    """One plugin type: where its implementation is and what its parameter namespace holds."""
    type: str
    implementation: str                 # "package.module:attribute", loaded by the ROS node
    params: type | None = None          # the parameter dataclass of its namespace (None: it has none)
    #: builds its configuration from its namespace (ROS 1 form, None when absent): (config, warnings);
    #: planners only, the ROS wrapper builds its own from the same namespace
    config: Callable[[dict | None], tuple[Any, list[str]]] | None = None

    def load(self) -> Any:
        module, _, attribute = self.implementation.partition(":")
        found = importlib.import_module(module)
        for part in attribute.split("."):
            found = getattr(found, part)
        return found


class PluginRegistry(Registry[PluginSpec]):
    """The types one move_base parameter (base_global_planner, ...) may name."""

    def __init__(self, parameter: str, specs=()):
        self.parameter = parameter
        super().__init__(specs)

    def key(self, spec: PluginSpec) -> str:
        return spec.type

    def conflict(self, spec: PluginSpec) -> str | None:
        return f"{self.parameter}: type {spec.type!r} is registered already" if spec.type in self._specs else None

    @property
    def types(self) -> tuple[str, ...]:
        return tuple(self._specs)

    def spec(self, plugin_type: str) -> PluginSpec:
        """The registration of a type; ParameterError naming the known types for any other."""
        try:
            return self._specs[plugin_type]
        except (KeyError, TypeError):
            raise ParameterError(f"{self.parameter}: unknown type {plugin_type!r}; "
                             f"known types: {', '.join(self._specs)}") from None


def _global_planner(given):
    config = GlobalPlannerConfig.from_params(given)
    return config, config.warnings


def _navfn(given):
    config = GlobalPlannerConfig.from_navfn_params(given)
    return config, config.warnings


def _teb(given):
    config = TebConfig.from_params(given)
    return config, config.warnings + FootprintModel.from_params(config.footprint_model).warnings


_ROS = "simplebot_navigation.ros.move_base"
GLOBAL_PLANNERS = PluginRegistry("base_global_planner", [
    PluginSpec(GLOBAL_PLANNER, f"{_ROS}.global_planner_ros:GlobalPlannerROS", GlobalPlannerConfig, _global_planner),
    PluginSpec(NAVFN, f"{_ROS}.global_planner_ros:GlobalPlannerROS", NavfnParams, _navfn),
])
LOCAL_PLANNERS = PluginRegistry("base_local_planner", [
    PluginSpec(TEB_LOCAL_PLANNER, f"{_ROS}.teb_local_planner_ros:TebLocalPlannerROS", TebConfig, _teb),
])
_RECOVERY = "simplebot_navigation.move_base.recovery"
RECOVERY_BEHAVIORS = PluginRegistry("recovery_behaviors", [
    PluginSpec(CLEAR_COSTMAP_RECOVERY, f"{_RECOVERY}.clear_costmap:create", ClearCostmapParams),
    PluginSpec(ROTATE_RECOVERY, f"{_RECOVERY}.rotate:create", RotateParams),
    PluginSpec(BACKUP_RECOVERY, f"{_RECOVERY}.backup:create", BackUpParams),
    PluginSpec(SPIN_RECOVERY, f"{_RECOVERY}.spin:create", SpinParams),
])


class GlobalPlannerPlugin(Protocol):
    """A global planner as move_base's node runs it (ROS 1's nav_core::BaseGlobalPlanner).

    Built once at start-up as ``cls(node, plugin_type, costmap_ros)``: it reads its namespace
    (``plugin_namespace(plugin_type)``) from the node's parameters and declares what it runs with. Every method
    is called on the node's executor thread; poses are (x, y, yaw) in the global costmap's frame."""

    def make_plan(self, start, goal, tolerance: float | None = None):
        """A plan from start to goal on the global costmap (take the costmap's lock to read it): a result with
        ``ok``, ``poses`` ((N, 3), empty on failure) and ``message`` (why not, for the log and the goal's
        status), as planning.global_planner.PlanResult. ``tolerance`` None: the planner's default. Called by
        the control cycle when a plan is due, and by the make_plan service."""

    def blocked_poses(self, poses: np.ndarray, robot_pose) -> np.ndarray:
        """Per row of the current plan: whether it now lies where the planner would not go (move_base replans
        when one ahead of the robot does). Called every control cycle while driving."""

    def reconfigure(self, config) -> None:
        """New values of its namespace while running, already checked: used from the next plan."""


@dataclass
class ControlResult:
    """One control cycle's answer: a velocity command, or ok False with the reason."""
    ok: bool
    v: float = 0.0
    omega: float = 0.0
    message: str = ""


class Controller(Protocol):
    """What move_base's state machine drives (MoveBaseCore), one call per control cycle on the executor thread."""

    def set_plan(self, plan: np.ndarray) -> bool:
        """A new global plan ((N, 3) in the global costmap's frame); False when it cannot be used."""

    def compute(self) -> ControlResult:
        """The velocity command of this cycle, or ``ok`` False with the reason."""

    def is_goal_reached(self) -> bool:
        """Within the goal tolerances, and slow enough to stop there."""

    def reset(self) -> None:
        """The goal ended or was preempted: forget the plan and any trajectory kept from it."""


class LocalPlannerPlugin(Controller, Protocol):
    """A local planner as move_base's node runs it (ROS 1's nav_core::BaseLocalPlanner): the Controller, plus
    what live parameter changes call, on the same thread between cycles.

    Built once at start-up as ``cls(node, plugin_type, costmap_ros, tf_buffer, controller_frequency,
    plan_frame, obstacle_feed)``, plan_frame being the global costmap's frame the plans come in and obstacle_feed
    the MovingObstacleFeed (perception/feed.py) every moving obstacle comes from."""

    def begin_cycle(self, pose) -> None:
        """The start of a control cycle that drives a goal: the robot pose (x, y, yaw, stamp) in the local
        costmap's frame, looked up once for the cycle (None when TF has none). ``compute`` and
        ``is_goal_reached`` of this cycle use it; a planner that moves its plan between frames does it here."""

    def reconfigure(self, config) -> None:
        """New values of its namespace, already checked (the registration's ``config`` built them)."""

    def set_controller_frequency(self, controller_frequency: float) -> None:
        """move_base's controller_frequency changed (Hz, already within bounds)."""

    def set_costmap_footprint(self, footprint: np.ndarray) -> None:
        """The local costmap's footprint changed ((N, 2) in the base frame, padded)."""
