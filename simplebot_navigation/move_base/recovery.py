"""Recovery behaviours, stepped by the control loop instead of blocking it.

ROS 1 runs a recovery inside the control loop and blocks it; stepping one
control period at a time keeps the node responsive (cancel, preemption) and the
simulation in lockstep.

Besides ROS 1's ClearCostmapRecovery and RotateRecovery, two behaviours modelled on Nav2's BackUp
and Spin get a robot out of places where it cannot turn a full circle (a box body nosed into a
gap): BackUpRecovery reverses along the path the robot came by (PoseTrail), which is known to be
free, and SpinRecovery turns as far as it can towards the side with more free space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE
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


@dataclass
class BackUpParams:
    """The ``<name>/`` namespace of a backup_recovery/BackUpRecovery (Nav2 BackUp's parameters)."""
    backup_dist: float = param(0.3, "m", "distance to reverse", gt=0)
    backup_speed: float = param(0.15, "m/s", "reversing speed", gt=0)
    max_rotational_vel: float = param(1.0, "rad/s", "turn rate limit while following the recent path", gt=0)
    simulate_ahead_time: float = param(2.0, "s", "motion checked for collisions ahead of each step", ge=0)
    time_allowance: float = param(10.0, "s", "time after which the behaviour gives up", gt=0)


@dataclass
class SpinParams:
    """The ``<name>/`` namespace of a spin_recovery/SpinRecovery (Nav2 Spin's parameters)."""
    spin_dist: float = param(math.pi / 2, "rad", "turn wanted towards the freer side", gt=0)
    max_rotational_vel: float = param(1.0, "rad/s", "maximum turn rate", gt=0)
    min_rotational_vel: float = param(0.4, "rad/s", "minimum turn rate", ge=0)
    rotational_acc_lim: float = param(3.2, "rad/s^2", "angular acceleration limit", gt=0)
    sim_granularity: float = param(0.017, "rad", "turn between two collision checks", gt=0)
    time_allowance: float = param(10.0, "s", "time after which the behaviour gives up", gt=0)


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


def _unicycle_poses(pose, v: float, omega: float, duration: float, step: float) -> np.ndarray:
    """Poses of a diff-drive robot holding (v, omega) from ``pose``, one per ``step`` seconds, the start excluded."""
    t = np.arange(1, max(1, int(math.ceil(duration / step))) + 1) * step
    yaw = pose[2] + omega * t
    if abs(omega) < 1e-9:
        x, y = pose[0] + v * t * math.cos(pose[2]), pose[1] + v * t * math.sin(pose[2])
    else:
        x = pose[0] + v / omega * (np.sin(yaw) - math.sin(pose[2]))
        y = pose[1] - v / omega * (np.cos(yaw) - math.cos(pose[2]))
    return np.column_stack([x, y, yaw])


class BackUpRecovery(ParameterisedRecovery):
    """Reverse backup_dist along the robot's recent path (straight back when it has none).

    footprint_clear(poses) says per (x, y, yaw) row whether the footprint is collision free; the
    motion of the next simulate_ahead_time is checked before every step, as Nav2's BackUp does.
    Nav2 gives up as soon as a collision shows up in that window; here the robot keeps reversing
    until the collision is STOP_MARGIN_S away, because in a tight spot every centimetre counts.
    """

    PARAMS = BackUpParams

    LOOKAHEAD_M = 0.15   # carrot distance along the trail: short, because the trail is what is known free
    CHECK_STEP_M = 0.01
    STOP_MARGIN_S = 0.25  # a few control periods of reversing

    def __init__(self, name: str, params: dict, footprint_clear: Callable[[np.ndarray], np.ndarray],
                 trail: PoseTrail):
        self.name = name
        self._clear = footprint_clear
        self._trail = trail
        self._route = np.empty((0, 2))
        self._start = 0.0
        self._driven = 0.0
        self._last = (0.0, 0.0)
        self.warnings = self.configure(params)

    def start(self, now: float, pose) -> None:
        x, y, yaw = pose
        self._route = self._trail.back_from(x, y, self.backup_dist + self.LOOKAHEAD_M)
        if not len(self._route):
            self._route = np.array([[x - math.cos(yaw) * self.backup_dist, y - math.sin(yaw) * self.backup_dist]])
        self._start, self._driven, self._last = now, 0.0, (x, y)

    def tick(self, now: float, pose) -> RecoveryStep:
        x, y, yaw = pose
        self._driven += math.hypot(x - self._last[0], y - self._last[1])
        self._last = (x, y)
        left = self.backup_dist - self._driven
        if left <= 0.01:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: backed up {self._driven:.2f} m")
        if now - self._start > self.time_allowance:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: gave up after {self.time_allowance:g} s, "
                                                  f"backed up {self._driven:.2f} m")
        omega = self._steer(x, y, yaw)
        step = self.CHECK_STEP_M / self.backup_speed
        duration = min(self.simulate_ahead_time, left / self.backup_speed)
        blocked = np.nonzero(~np.asarray(self._clear(_unicycle_poses(pose, -self.backup_speed, omega, duration,
                                                                      step)), dtype=bool))[0]
        if len(blocked) and (blocked[0] + 1) * step < self.STOP_MARGIN_S:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: stopped after {self._driven:.2f} m, "
                                                  "a collision lies behind the robot")
        return RecoveryStep((-self.backup_speed, omega), False)

    def _steer(self, x: float, y: float, yaw: float) -> float:
        """Pure pursuit in reverse: the turn rate that brings the rear onto the carrot point."""
        distances = np.hypot(self._route[:, 0] - x, self._route[:, 1] - y)
        nearest = int(np.argmin(distances))
        beyond = np.nonzero(distances[nearest:] >= self.LOOKAHEAD_M)[0]
        tx, ty = self._route[nearest + beyond[0]] if len(beyond) else self._route[-1]
        alpha = normalize_theta(math.atan2(ty - y, tx - x) - (yaw + math.pi))
        if abs(alpha) > math.pi / 2:   # the carrot lies ahead: the trail turned sharper than reversing can
            return 0.0
        curvature = 2.0 * math.sin(alpha) / max(math.hypot(tx - x, ty - y), 1e-3)
        return float(np.clip(self.backup_speed * curvature, -self.max_rotational_vel, self.max_rotational_vel))


def free_area_left_right(costmap, pose, radius: float) -> tuple[float, float]:
    """Known free area (m^2, cells below the inscribed cost) within ``radius`` on the robot's left and right."""
    x, y, yaw = pose
    res = costmap.resolution
    offsets = np.arange(-radius, radius + res, res)
    dx, dy = np.meshgrid(offsets, offsets)
    inside = np.hypot(dx, dy) <= radius
    dx, dy = dx[inside], dy[inside]
    mx, my, on_map = costmap.world_to_map_array(x + dx, y + dy)
    cost = costmap.costmap[my[on_map], mx[on_map]]
    free = (cost < INSCRIBED_INFLATED_OBSTACLE)
    lateral = (-math.sin(yaw) * dx + math.cos(yaw) * dy)[on_map]
    return float(free[lateral > 0].sum() * res * res), float(free[lateral < 0].sum() * res * res)


class SpinRecovery(ParameterisedRecovery):
    """Turn spin_dist in place towards the side with more free space, or as far as the footprint can.

    free_space(pose) gives the free area on the robot's left and right; footprint_clear(poses)
    checks each (x, y, yaw) row. Where a full circle is blocked, part of a turn still changes
    what the local planner can start from.
    """

    PARAMS = SpinParams

    def __init__(self, name: str, params: dict, footprint_clear: Callable[[np.ndarray], np.ndarray],
                 free_space: Callable[[tuple[float, float, float]], tuple[float, float]]):
        self.name = name
        self._clear = footprint_clear
        self._free_space = free_space
        self._target = 0.0      # signed turn to make
        self._turned = 0.0
        self._last_yaw = 0.0
        self._start = 0.0
        self._refused = ""
        self.warnings = self.configure(params)

    def _reachable(self, pose, direction: float) -> float:
        """How far (rad, up to spin_dist) the footprint turns in ``direction`` before a collision."""
        steps = np.arange(1, int(self.spin_dist / self.sim_granularity) + 1) * self.sim_granularity
        steps = np.append(steps, self.spin_dist) if not len(steps) or steps[-1] < self.spin_dist else steps
        poses = np.column_stack([np.full_like(steps, pose[0]), np.full_like(steps, pose[1]),
                                 pose[2] + direction * steps])
        blocked = np.nonzero(~np.asarray(self._clear(poses), dtype=bool))[0]
        if not len(blocked):
            return self.spin_dist
        return float(steps[blocked[0] - 1]) if blocked[0] > 0 else 0.0

    def start(self, now: float, pose) -> None:
        left_free, right_free = self._free_space(pose)
        preferred = 1.0 if left_free >= right_free else -1.0
        reach = {d: self._reachable(pose, d) for d in (preferred, -preferred)}
        # the freer side, unless the footprint turns clearly further the other way
        direction = preferred if reach[preferred] >= 0.5 * reach[-preferred] else -preferred
        self._target = direction * reach[direction]
        self._refused = "" if reach[direction] > self.sim_granularity else \
            f"{self.name}: can't turn in place either way because there is a potential collision"
        self._turned, self._last_yaw, self._start = 0.0, pose[2], now

    def tick(self, now: float, pose) -> RecoveryStep:
        if self._refused:
            return RecoveryStep((0.0, 0.0), True, self._refused)
        self._turned += float(normalize_theta(pose[2] - self._last_yaw))
        self._last_yaw = pose[2]
        left = abs(self._target) - math.copysign(1.0, self._target) * self._turned
        side = "left" if self._target > 0 else "right"
        if left < 0.03:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: turned {abs(self._turned):.2f} rad to the {side}")
        if now - self._start > self.time_allowance:
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: gave up after {self.time_allowance:g} s")
        direction = math.copysign(1.0, self._target)
        sweep = np.arange(1, max(1, int(left / self.sim_granularity)) + 1) * self.sim_granularity
        poses = np.column_stack([np.full_like(sweep, pose[0]), np.full_like(sweep, pose[1]),
                                 pose[2] + direction * sweep])
        if not np.all(self._clear(poses)):
            return RecoveryStep((0.0, 0.0), True, f"{self.name}: stopped after {abs(self._turned):.2f} rad "
                                                  f"to the {side}, a collision lies further")
        speed = min(self.max_rotational_vel, max(self.min_rotational_vel,
                                                 math.sqrt(2.0 * self.rotational_acc_lim * left)))
        return RecoveryStep((0.0, direction * speed), False)


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


class RotateRecovery(ParameterisedRecovery):
    """Turn a full circle in place (counter-clockwise) to let the sensors see everything around.

    footprint_clear(poses) says per (x, y, yaw) row whether the footprint is collision free on the
    local costmap; the remaining turn is checked every sim_granularity before each step, as ROS 1 does.
    """

    PARAMS = RotateParams

    def __init__(self, name: str, params: dict, footprint_clear: Callable[[np.ndarray], np.ndarray]):
        self.name = name
        self._clear = footprint_clear
        self._start_yaw = 0.0
        self._turned = 0.0
        self._last_yaw = 0.0
        self.warnings = self.configure(params)

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
        if not np.all(self._clear(np.column_stack([np.full_like(yaws, x), np.full_like(yaws, y), yaws]))):
            return RecoveryStep((0.0, 0.0), True,
                                f"{self.name}: can't rotate in place because there is a potential collision")
        speed = min(self.max_vel_theta, max(self.min_in_place_vel_theta,
                                            math.sqrt(2.0 * self.acc_lim_theta * dist_left)))
        return RecoveryStep((0.0, speed), False)
