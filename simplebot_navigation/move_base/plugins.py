"""move_base's plugins: the registries of its three kinds and the interfaces their implementations satisfy.

Each plugin's own module declares it with a ``PluginSpec`` (simplebot_navigation/pluginlib.py), and one line
of pyproject.toml's entry points names that spec: ``simplebot_navigation.global_planners``,
``simplebot_navigation.local_planners`` or ``simplebot_navigation.recovery_behaviors``. Everything below the
ROS layer (the parameter tree, ``--print-params``, live parameters, the "unknown type" message) reads the
registrations; the ROS node loads the implementation of the types a configuration selects. The interfaces are
documented where they are used: ``GlobalPlannerPlugin`` and ``LocalPlannerPlugin`` below for the ROS wrappers,
``Recovery`` and ``RecoveryContext`` in move_base/recovery/, ``Layer`` in costmap/layer.py; docs/plugins.md
shows how to add one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.pluginlib import PluginSpec, Registry


def plugin_namespace(plugin_type: str) -> str:
    """A plugin's parameter namespace as ROS 1 move_base derives it: the class name after the '/'."""
    return plugin_type.rpartition("/")[2]


class PluginRegistry(Registry[PluginSpec]):
    """The types one move_base parameter (base_global_planner, ...) may name."""

    spec_type = PluginSpec

    def __init__(self, parameter: str, group: str):
        self.parameter = parameter
        super().__init__(group)

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


GLOBAL_PLANNERS = PluginRegistry("base_global_planner", "simplebot_navigation.global_planners")
LOCAL_PLANNERS = PluginRegistry("base_local_planner", "simplebot_navigation.local_planners")
RECOVERY_BEHAVIORS = PluginRegistry("recovery_behaviors", "simplebot_navigation.recovery_behaviors")


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
