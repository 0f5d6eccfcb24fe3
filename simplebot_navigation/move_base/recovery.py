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


def _param(params: dict, key: str, default, kind):
    value = params.get(key, default)
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or (kind is float and not math.isfinite(value)):
        raise ValueError(f"recovery parameter {key}: expected {kind.__name__}, got {value!r}")
    return value


class ClearCostmapRecovery:
    """Forget obstacles outside a square of side reset_distance around the robot (inside with invert).

    clear(costmap, x, y, reset_distance, layer_names, invert) is called for each affected costmap.
    Unlike ROS 1, layer_names defaults to every obstacle-type layer that exists (DESIGN §9).
    """

    def __init__(self, name: str, params: dict, costmaps: dict[str, object],
                 clear: Callable[..., list[str]], default_reset_distance: float):
        self.name = name
        self.reset_distance = _param(params, "reset_distance", default_reset_distance, float)
        self.invert_area = _param(params, "invert_area_to_clear", False, bool)
        self.force_updating = _param(params, "force_updating", False, bool)
        affected = params.get("affected_maps", "both")
        self.warnings: list[str] = []
        if affected not in ("local", "global", "both"):
            self.warnings.append(f"{name}: affected_maps {affected!r} is not local, global or both; using both")
            affected = "both"
        self.costmaps = [cm for key, cm in costmaps.items() if affected == "both" or key == affected]
        names = params.get("layer_names")
        if names is not None and (not isinstance(names, list) or not all(isinstance(n, str) for n in names)):
            raise ValueError(f"recovery parameter {name}/layer_names: expected a list of layer names, got {names!r}")
        self.layer_names = names
        self._clear = clear
        self.cleared: list[str] = []

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
        self.sim_granularity = _param(params, "sim_granularity", 0.017, float)
        self.acc_lim_theta = _param(params, "acc_lim_theta", 3.2, float)
        self.max_vel_theta = _param(params, "max_vel_theta", 1.0, float)
        self.min_in_place_vel_theta = _param(params, "min_in_place_vel_theta", 0.4, float)
        self.yaw_goal_tolerance = _param(params, "yaw_goal_tolerance", 0.10, float)
        self._free = footprint_free
        self._start_yaw = 0.0
        self._turned = 0.0
        self._last_yaw = 0.0

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
