"""Recovery behaviours, stepped by the control loop instead of blocking it.

ROS 1 runs a recovery inside the control loop and blocks it; stepping one
control period at a time keeps the node responsive (cancel, preemption) and the
simulation in lockstep.

Besides ROS 1's ClearCostmapRecovery and RotateRecovery, two behaviours modelled on Nav2's BackUp
and Spin get a robot out of places where it cannot turn a full circle (a box body nosed into a
gap): BackUpRecovery reverses along the path the robot came by (PoseTrail), which is known to be
free, and SpinRecovery turns as far as it can towards the side with more free space. Their turns and
drives are move_base/motion.py's, which Nav2's behaviours (behaviors.py) are made of too.

A behaviour is a module of this package with a class that satisfies ``Recovery``, a ``create(context,
name, params)`` factory and its registration, ``SPEC``: a PluginSpec of its type name, the factory and its
parameter class, named by a ``simplebot_navigation.recovery_behaviors`` entry point (docs/plugins.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from simplebot_navigation.parameters import PLUGIN_TYPE_KEY, build, fields_of


@dataclass
class RecoveryStep:
    """One control period of a recovery: the velocity to send (None: none) and whether it is over."""
    cmd: tuple[float, float] | None
    done: bool
    message: str = ""


class Recovery(Protocol):
    """A recovery behaviour, ROS 1's nav_core::RecoveryBehavior stepped one control period at a time.

    Its factory builds it once per behaviour name when move_base starts. Every method is called by move_base's
    control cycle on the node's executor thread, never two at once. Poses are (x, y, yaw) in the global
    costmap's frame, times are node-clock seconds."""
    name: str
    warnings: list[str]     # logged once, after the factory built it

    def start(self, now: float, pose: tuple[float, float, float]) -> None:
        """The behaviour begins (the robot has been told to stop): reset what the last run left."""

    def tick(self, now: float, pose: tuple[float, float, float]) -> RecoveryStep:
        """One control period: the velocity to send (None: send nothing) and whether it is over, with a message
        for the log when it is."""

    def configure(self, params: dict) -> list[str]:
        """Its ``<name>/`` namespace (ROS 1 form), at start-up from the factory and again when a live parameter
        change touched it (already checked against the parameter class): take it; the warnings to log."""

    def parameters(self) -> dict:
        """The values it runs with, by key: declared on the node as ``<name>.<key>``."""


class RecoveryContext(Protocol):
    """What a behaviour may act on, given to its factory; the ROS node implements it over its costmaps. The
    callables are safe to call from the control cycle (they take the costmaps' locks)."""
    trail: PoseTrail                 # where the robot came from
    costmaps: dict[str, object]      # "global" and "local", for clear_costmap
    circumscribed_radius: float      # of the local costmap's footprint
    conservative_reset_dist: float   # move_base's parameter

    def footprint_clear(self, poses: np.ndarray) -> np.ndarray:
        """Per (x, y, yaw) row: the footprint there touches no lethal or unknown cell of the local costmap."""

    def free_space(self, pose, radius: float) -> tuple[float, float]:
        """Free area (m^2) within radius on the left and the right of the pose, on the local costmap."""

    def clear_costmap(self, costmap, x: float, y: float, reset_distance: float, layer_names, invert: bool,
                      force_updating: bool) -> list[str]:
        """Clear ``costmap`` (a value of ``costmaps``) outside the square around the robot; the layers cleared."""

    def planner_parameters(self, namespace: str) -> dict:
        """The parameters move_base was given under another namespace (ROS 1 form), e.g. a planner's."""


#: the implementation a behaviour's PluginSpec gives: (context, name, params) -> Recovery
RecoveryFactory = Callable[[RecoveryContext, str, dict], Recovery]


class ParameterisedRecovery:
    """A behaviour whose parameters are the fields of ``PARAMS``, kept as attributes of the same names."""
    PARAMS: type

    def configure(self, params: dict) -> list[str]:
        """Take the behaviour's parameters (at start-up, and when they change while running); the warnings."""
        p, warnings = build(self.PARAMS, params, f"move_base/{self.name}", also_known=[PLUGIN_TYPE_KEY])
        for key in fields_of(self.PARAMS):
            setattr(self, key, getattr(p, key))
        return warnings

    def parameters(self) -> dict:
        """The parameters it runs with, under their names (to declare on the node)."""
        return {key: getattr(self, key) for key in fields_of(self.PARAMS)}


class PoseTrail:
    """The positions the robot came by, a point every ``spacing``, without loops: coming back within
    ``spacing`` of an earlier point cuts the trail there, so reversing along it never leads back
    into the place the robot is leaving."""

    def __init__(self, spacing: float = 0.05, max_points: int = 200):
        self.spacing = spacing
        self.max_points = max_points
        self._points = np.empty((0, 2))

    def __len__(self) -> int:
        return len(self._points)

    def record(self, x: float, y: float) -> None:
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        pts = self._points
        if len(pts):
            near = np.nonzero(np.hypot(pts[:-1, 0] - x, pts[:-1, 1] - y) < self.spacing)[0]
            if len(near):
                self._points = pts[:near[-1] + 1]
                return
            if math.hypot(pts[-1, 0] - x, pts[-1, 1] - y) < self.spacing:
                return
        self._points = np.vstack([pts, [[x, y]]])[-self.max_points:]

    def back_from(self, x: float, y: float, distance: float) -> np.ndarray:
        """The trail from (x, y) backwards, up to ``distance`` of it (rows x, y; empty when unknown)."""
        route = np.vstack([[[x, y]], self._points[::-1]])
        steps = np.hypot(*np.diff(route, axis=0).T)
        along = np.concatenate([[0.0], np.cumsum(steps)])
        return route[1:int(np.searchsorted(along, distance, side="right"))]

    def clear(self) -> None:
        self._points = np.empty((0, 2))
