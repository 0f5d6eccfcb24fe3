"""Recovery behaviours, stepped by the control loop instead of blocking it.

ROS 1 runs a recovery inside the control loop and blocks it; stepping one
control period at a time keeps the node responsive (cancel, preemption) and the
simulation in lockstep.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.parameters import PLUGIN_TYPE_KEY, ParameterError, build, fields_of, param


@dataclass
class RecoveryStep:
    """One control period of a recovery: the velocity to send (None: none) and whether it is over."""
    cmd: tuple[float, float] | None
    done: bool
    message: str = ""


class Recovery(Protocol):
    name: str

    def start(self, now: float, pose: tuple[float, float, float]) -> None: ...

    def tick(self, now: float, pose: tuple[float, float, float]) -> RecoveryStep: ...


@dataclass
class ClearCostmapParams:
    """The ``<name>/`` namespace of a clear_costmap_recovery/ClearCostmapRecovery."""
    reset_distance: float = param(3.0, "m", "side of the square kept (default: conservative_reset_dist for "
                                  "conservative_reset, else 4 x the circumscribed radius)", ge=0)
    invert_area_to_clear: bool = param(False, "", "clear inside the square instead of outside")
    force_updating: bool = param(False, "", "update the costmap right after clearing")
    affected_maps: str = param("both", "", "costmaps to clear: local, global or both")
    layer_names: list = param(None, "", "layers to clear (default: every obstacle-type layer)", kind=list)


@dataclass
class RotateParams:
    """The ``<name>/`` namespace of a rotate_recovery/RotateRecovery (the speed limits are also read from
    TrajectoryPlannerROS, as ROS 1 does)."""
    sim_granularity: float = param(0.017, "rad", "turn between two collision checks", gt=0)
    acc_lim_theta: float = param(3.2, "rad/s^2", "angular acceleration limit", gt=0)
    max_vel_theta: float = param(1.0, "rad/s", "maximum turn rate", gt=0)
    min_in_place_vel_theta: float = param(0.4, "rad/s", "minimum turn rate", ge=0)
    yaw_goal_tolerance: float = param(0.10, "rad", "turn left over when the circle counts as done", ge=0)


class ClearCostmapRecovery:
    """Forget obstacles outside a square of side reset_distance around the robot (inside with invert).

    clear(costmap, x, y, reset_distance, layer_names, invert) is called for each affected costmap.
    Unlike ROS 1, layer_names defaults to every obstacle-type layer that exists (docs/design.md §9).
    """

    def __init__(self, name: str, params: dict, costmaps: dict[str, object],
                 clear: Callable[..., list[str]], default_reset_distance: float):
        self.name = name
        self._all_costmaps = costmaps
        self._default_reset_distance = default_reset_distance
        self._clear = clear
        self.cleared: list[str] = []
        self.warnings = self.configure(params)

    def configure(self, params: dict) -> list[str]:
        """Take the behaviour's parameters (at start-up, and when they change while running); the warnings."""
        p, warnings = build(ClearCostmapParams, params, f"move_base/{self.name}", also_known=[PLUGIN_TYPE_KEY])
        if p.layer_names is not None and not all(isinstance(n, str) for n in p.layer_names):
            raise ParameterError(f"move_base/{self.name}/layer_names: expected a list of layer names, "
                                 f"got {p.layer_names!r}")
        self.reset_distance = p.reset_distance if "reset_distance" in params else self._default_reset_distance
        self.invert_area = p.invert_area_to_clear
        self.force_updating = p.force_updating
        self.affected_maps = affected = p.affected_maps
        if affected not in ("local", "global", "both"):
            warnings.append(f"move_base/{self.name}/affected_maps: {affected!r} is not local, global or both; "
                            "using both")
            affected = "both"
        self.costmaps = [cm for key, cm in self._all_costmaps.items() if affected == "both" or key == affected]
        self.layer_names = p.layer_names
        return warnings

    def parameters(self) -> dict:
        """The parameters it runs with, under their names (to declare on the node)."""
        values = {"reset_distance": self.reset_distance, "invert_area_to_clear": self.invert_area,
                  "force_updating": self.force_updating, "affected_maps": self.affected_maps}
        return values if self.layer_names is None else {**values, "layer_names": list(self.layer_names)}

    def start(self, now: float, pose) -> None:
        self.cleared = []
        for costmap in self.costmaps:
            self.cleared += self._clear(costmap, pose[0], pose[1], self.reset_distance, self.layer_names,
                                        self.invert_area, self.force_updating)

    def tick(self, now: float, pose) -> RecoveryStep:
        what = ", ".join(self.cleared) or "no layer"
        side = "inside" if self.invert_area else "outside"
        return RecoveryStep(None, True, f"{self.name}: cleared {what} {side} a {self.reset_distance:.2f} m square")


class RotateRecovery:
    """Turn a full circle in place (counter-clockwise) to let the sensors see everything around.

    footprint_free(poses) says whether the footprint is collision free at every (x, y, yaw) row on the
    local costmap; the remaining turn is checked every sim_granularity before each step, as ROS 1 does.
    """

    def __init__(self, name: str, params: dict, footprint_free: Callable[[np.ndarray], bool]):
        self.name = name
        self._free = footprint_free
        self._start_yaw = 0.0
        self._turned = 0.0
        self._last_yaw = 0.0
        self.warnings = self.configure(params)

    def configure(self, params: dict) -> list[str]:
        """Take the behaviour's parameters (at start-up, and when they change while running); the warnings."""
        p, warnings = build(RotateParams, params, f"move_base/{self.name}", also_known=[PLUGIN_TYPE_KEY])
        for key in fields_of(RotateParams):
            setattr(self, key, getattr(p, key))
        return warnings

    def parameters(self) -> dict:
        """The parameters it runs with, under their names (to declare on the node)."""
        return {key: getattr(self, key) for key in fields_of(RotateParams)}

    def start(self, now: float, pose) -> None:
        self._start_yaw = self._last_yaw = pose[2]
        self._turned = 0.0

    def tick(self, now: float, pose) -> RecoveryStep:
        x, y, yaw = pose
        self._turned += float(normalize_theta(yaw - self._last_yaw))
        self._last_yaw = yaw
        dist_left = 2.0 * math.pi - self._turned
        if dist_left < self.yaw_goal_tolerance:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: turned a full circle")
        yaws = yaw + np.linspace(0.0, dist_left, max(1, int(dist_left / self.sim_granularity)) + 1)
        if not self._free(np.column_stack([np.full_like(yaws, x), np.full_like(yaws, y), yaws])):
            return RecoveryStep((0.0, 0.0), True,
                                f"{self.name}: can't rotate in place because there is a potential collision")
        speed = min(self.max_vel_theta, max(self.min_in_place_vel_theta,
                                            math.sqrt(2.0 * self.acc_lim_theta * dist_left)))
        return RecoveryStep((0.0, speed), False)
