"""global_planner/GlobalPlanner (and navfn/NavfnROS) on a Costmap2D (docs/reference.md §3).

Pipeline of one make_plan call, as in ROS 1: clear the robot's cell in the costmap, outline the
map, map raw costs to per-cell step costs, expand a potential from the start (Dijkstra wavefront
or A*), give the goal's neighbourhood a potential (clearEndpoint), descend the potential from
the goal to the start (gradient or grid path), convert to world coordinates, append the goal
and orient the poses.

Deliberate differences from ROS 1:
- ``default_tolerance`` and the request tolerance are honoured (ROS 1 global_planner ignores
  them): if the goal cannot be reached, the plan ends at the nearest reachable cell centre
  within the tolerance.
- The expansion stops when the cell *containing* the goal has a potential. ROS 1 waits for the
  lattice node below-left of the goal point, which is an obstacle cell whenever the goal lies
  in the lower/left half of a cell next to one, and then fails although the goal is free.
- A* (and clearEndpoint) step costs are ``cost + neutral_cost`` without ROS's unsigned-char
  wrap-around, which makes costs >= 206, and unknown space, *cheaper* than free space.
- Buckets never drop cells (ROS's 10 000-entry ring buffers silently do on large maps).
- The precise start seeds a symmetric 3 x 3 block of nodes with true distances (see _seeds).
- Path extraction gets past a zero gradient (ROS 1 fails there) and the grid path ends next
  to the start instead of oscillating around it (see path_kernels).
- ForwardThenInterpolate blends from the last straight section's heading (see orientation).
- navfn mode keeps navfn's cost mapping, border blocking, tolerance search and un-oriented
  poses, but places path points on cell centres (navfn converts with ``origin + m * res``,
  half a cell off) and, like it, starts the wave from the robot's cell.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.planning import expansion_kernels, path_kernels
from simplebot_navigation.planning.config import GLOBAL_PLANNER, NAVFN, GlobalPlannerConfig
from simplebot_navigation.planning.expansion_kernels import POT_HIGH
from simplebot_navigation.planning.orientation import orient_path

# navfn's constants (navfn.h).
_NAVFN_NEUTRAL = 50
_NAVFN_FACTOR = 0.8
_NAVFN_OBSTACLE = 254
# clearEndpoint window half-size (cells).
_END_WINDOW = 2


class PlanFailure(enum.Enum):
    START_OFF_MAP = "start off the costmap"
    GOAL_OFF_MAP = "goal off the costmap"
    GOAL_IN_LETHAL = "goal in lethal space"
    NO_PATH = "no path"
    PATH_EXTRACTION = "path extraction failed"


@dataclass
class PlanResult:
    """Outcome of one make_plan call.

    ``poses`` is (N, 3) [x, y, yaw] in the costmap frame, empty on failure. ``potential`` is
    the (size_y, size_x) float32 potential ([my, mx], values >= POT_HIGH unassigned), or None
    when planning failed before the expansion. ``cost`` is the line integral of the planner's
    per-cell step cost along the path (cost units x cells); ``length`` is in metres.
    ``goal`` is the point the plan ends at: the requested goal, or its substitute within the
    tolerance.
    """
    ok: bool
    poses: np.ndarray
    failure: PlanFailure | None = None
    message: str = ""
    potential: np.ndarray | None = None
    cost: float = 0.0
    length: float = 0.0
    goal: tuple[float, float, float] | None = None


def global_planner_costs(lethal_cost: int, neutral_cost: int, cost_factor: float,
                         allow_unknown: bool) -> np.ndarray:
    """DijkstraExpansion::getCost for raw costs 0..255; +inf where the cell is blocked.

    ``min(c * cost_factor + neutral_cost, lethal_cost - 1)`` for c < lethal_cost - 1 (and for
    unknown when allowed), truncated to an integer as the potential calculator's unsigned-char
    argument does. With the defaults every c >= 68 saturates at 252: the cost plateau.
    """
    c = np.arange(256, dtype=np.float32)
    cost = np.minimum(np.trunc(c * np.float32(cost_factor) + np.float32(neutral_cost)),
                      np.float32(lethal_cost - 1))
    passable = c < lethal_cost - 1
    if allow_unknown:
        passable[NO_INFORMATION] = True
    return np.where(passable, cost, np.inf).astype(np.float32)


def navfn_costs(allow_unknown: bool) -> np.ndarray:
    """NavFn::setCostmap for raw costs 0..255; +inf where blocked (navfn's 254).

    ``int(50 + 0.8 c)`` (at most 253) for c < 253; 253/254 are obstacles; unknown is 253 when
    allowed. No plateau: 0->50, 10->58, 100->130, 200->210, 252->251.
    """
    c = np.arange(256)
    cost = np.minimum((_NAVFN_NEUTRAL + _NAVFN_FACTOR * c).astype(np.int64), _NAVFN_OBSTACLE - 1)
    cost = cost.astype(np.float32)
    cost[253:] = np.inf
    if allow_unknown:
        cost[NO_INFORMATION] = _NAVFN_OBSTACLE - 1
    return cost


def astar_costs(lethal_cost: int, neutral_cost: int, allow_unknown: bool) -> np.ndarray:
    """AStarExpansion step cost ``c + neutral_cost`` (cost_factor unused); +inf where blocked."""
    c = np.arange(256)
    cost = (c + neutral_cost).astype(np.float32)
    blocked = c >= lethal_cost
    if allow_unknown:
        blocked[NO_INFORMATION] = False
    cost[blocked] = np.inf
    return cost


def potential_to_occupancy(potential: np.ndarray, publish_scale: int) -> np.ndarray:
    """The ``potential`` OccupancyGrid data: pot * publish_scale / max, -1 where unassigned."""
    assigned = potential < POT_HIGH
    out = np.full(potential.shape, -1, dtype=np.int8)
    peak = float(potential[assigned].max()) if assigned.any() else 0.0
    if peak > 0.0:
        out[assigned] = (potential[assigned].astype(np.float64) * publish_scale / peak).astype(np.int8)
    return out


def _check_pose(name: str, pose) -> tuple[float, float, float]:
    try:
        x, y, yaw = (float(v) for v in pose)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be (x, y, yaw), got {pose!r}") from None
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise ValueError(f"{name} must be finite, got {pose!r}")
    return x, y, yaw


class GlobalPlanner:
    """global_planner/GlobalPlanner, or navfn/NavfnROS when ``config.navfn``."""

    def __init__(self, config: GlobalPlannerConfig | None = None):
        self.config = config or GlobalPlannerConfig()
        cfg = self.config
        if cfg.navfn:
            self._costs = navfn_costs(cfg.allow_unknown)
            self._threshold0 = float(_NAVFN_OBSTACLE)
            self._neutral = _NAVFN_NEUTRAL
        elif cfg.use_dijkstra:
            self._costs = global_planner_costs(cfg.lethal_cost, cfg.neutral_cost, cfg.cost_factor,
                                               cfg.allow_unknown)
            self._threshold0 = float(cfg.lethal_cost)
            self._neutral = cfg.neutral_cost
        else:
            self._costs = astar_costs(cfg.lethal_cost, cfg.neutral_cost, cfg.allow_unknown)
            self._threshold0 = float(cfg.lethal_cost)
            self._neutral = cfg.neutral_cost
        # Cost used for the plan's reported cost: blocked cells count as lethal_cost.
        self._metric_costs = np.where(np.isinf(self._costs), self._threshold0,
                                      self._costs).astype(np.float64)
        # old_navfn_behavior (and navfn) plan between whole cells without a precise start.
        self._precise = not (cfg.old_navfn_behavior or cfg.navfn)
        self._offset = 0.0 if cfg.old_navfn_behavior else 0.5

    # -- public ----------------------------------------------------------------------------
    def make_plan(self, costmap: Costmap2D, start, goal, tolerance: float | None = None
                  ) -> PlanResult:
        """Plan from ``start`` to ``goal`` ((x, y, yaw) in the costmap frame).

        Side effects on ``costmap``, as ROS 1: the start cell is set FREE (clearRobotCell) and,
        with ``outline_map``, the border cells are set LETHAL.

        ``tolerance`` (metres; None = ``default_tolerance``) is honoured, unlike ROS 1
        global_planner: when the goal cell cannot be reached, the plan ends at the nearest
        cell centre with a potential within ``tolerance`` of the goal, with the goal's yaw;
        with tolerance 0 a goal in lethal space fails with GOAL_IN_LETHAL. In navfn mode the
        search is navfn's: a square of points spaced one resolution apart, the goal may then
        even lie off the map, and the plan ends at the best point.
        """
        cfg = self.config
        sx, sy, syaw = _check_pose("start", start)
        gx, gy, gyaw = _check_pose("goal", goal)
        tol = cfg.default_tolerance if tolerance is None else float(tolerance)
        if not (math.isfinite(tol) and tol >= 0.0):
            raise ValueError(f"tolerance must be finite and >= 0, got {tolerance!r}")

        start_cell = costmap.world_to_map(sx, sy)
        if start_cell is None:
            return self._fail(PlanFailure.START_OFF_MAP,
                              f"the robot's start position ({sx:.3f}, {sy:.3f}) is off the "
                              f"global costmap; is the robot localised?")
        goal_cell = costmap.world_to_map(gx, gy)
        if goal_cell is None and not (cfg.navfn and tol > 0.0):
            return self._fail(PlanFailure.GOAL_OFF_MAP,
                              f"the goal ({gx:.3f}, {gy:.3f}) is off the global costmap")

        nx, ny = costmap.size_x, costmap.size_y
        width = nx + 2
        cost = self._step_costs(costmap, start_cell)

        if goal_cell is not None and tol == 0.0 and math.isinf(cost[self._index(goal_cell, width)]):
            raw = costmap.get_cost(*goal_cell)
            return self._fail(PlanFailure.GOAL_IN_LETHAL,
                              f"the goal ({gx:.3f}, {gy:.3f}) lies in cell {goal_cell} of cost "
                              f"{raw}, which the planner cannot enter, and the tolerance is 0")

        su, sv = self._lattice(costmap, sx, sy)
        if not self._precise:
            su, sv = float(start_cell[0]), float(start_cell[1])
        pot = np.full((ny + 2) * width, POT_HIGH, dtype=np.float32)
        goal_index = self._index(goal_cell, width) if goal_cell is not None else 0
        reached = self._expand(cost, pot, width, su, sv, start_cell, goal_index)
        potential = pot.reshape(ny + 2, width)[1:-1, 1:-1]

        target = self._target(costmap, potential, (gx, gy), goal_cell, reached, tol)
        if target is None:
            why = ("no reachable point within the tolerance" if tol > 0.0 else
                   "the goal cannot be reached from the start")
            return self._fail(PlanFailure.NO_PATH, f"no path to ({gx:.3f}, {gy:.3f}): {why}",
                              potential)
        return self._extract_path(costmap, pot, (su, sv), target, (syaw, gyaw), potential)

    def _step_costs(self, costmap: Costmap2D, start_cell) -> np.ndarray:
        """The flat per-cell step costs with a one-cell border, after ROS 1's side effects on the costmap."""
        costmap.set_cost(*start_cell, FREE_SPACE)
        if self.config.outline_map:
            grid = costmap.costmap
            grid[0, :] = grid[-1, :] = LETHAL_OBSTACLE
            grid[:, 0] = grid[:, -1] = LETHAL_OBSTACLE
        cost = np.empty((costmap.size_y + 2, costmap.size_x + 2), np.float32)
        expansion_kernels.fill_padded_costs(costmap.costmap, self._costs, self.config.navfn, cost)
        return cost.ravel()

    def _extract_path(self, costmap: Costmap2D, pot: np.ndarray, start_uv, target, yaws, potential) -> PlanResult:
        """The path down the potential from the target back to the start, as poses from the start."""
        cfg = self.config
        nx, ny, width = costmap.size_x, costmap.size_y, costmap.size_x + 2
        (su, sv), (tx, ty), (syaw, gyaw) = start_uv, target, yaws
        target_cell = costmap.world_to_map(tx, ty)
        if self._precise:
            tu, tv = self._lattice(costmap, tx, ty)
            expansion_kernels.clear_endpoint(costmap.costmap, pot, width, target_cell[0], target_cell[1],
                                   _END_WINDOW, float(self._neutral), cfg.use_quadratic)
        else:
            tu, tv = float(target_cell[0]), float(target_cell[1])

        extract = path_kernels.grid_path if cfg.use_grid_path else path_kernels.gradient_path
        points, count, status = extract(pot, width, su, sv, tu, tv, 4 * nx * ny)
        if status != 0:
            return self._fail(PlanFailure.PATH_EXTRACTION,
                              f"a potential reached the goal but the path could not be extracted "
                              f"({_EXTRACTION_ERRORS[status]})", potential)

        lattice = points[count - 1::-1]
        xy = np.empty((count, 2))
        xy[:, 0] = costmap.origin_x + (lattice[:, 0] + self._offset) * costmap.resolution
        xy[:, 1] = costmap.origin_y + (lattice[:, 1] + self._offset) * costmap.resolution
        tail = [[tx, ty]] * (2 if cfg.old_navfn_behavior else 1)
        xy = np.vstack([xy, tail])
        yaw = orient_path(xy, syaw, gyaw, cfg.orientation_mode, cfg.orientation_window_size)
        poses = np.column_stack([xy, yaw])
        length, plan_cost = self._measure(costmap, xy)
        return PlanResult(True, poses, potential=potential, cost=plan_cost, length=length,
                          goal=(tx, ty, gyaw))

    def blocked_poses(self, costmap: Costmap2D, poses: np.ndarray) -> np.ndarray:
        """Which poses lie on a cell this planner would not enter now (poses off the costmap are
        not judged). Away from the start, a plan crosses such a cell only after the costmap has
        changed under it: the obstacle was seen after planning."""
        mx, my, valid = costmap.world_to_map_array(poses[:, 0], poses[:, 1])
        blocked = np.zeros(len(poses), dtype=bool)
        blocked[valid] = np.isinf(self._costs[costmap.costmap[my[valid], mx[valid]]])
        return blocked

    # -- steps -------------------------------------------------------------------------------
    def _expand(self, cost, pot, width, su, sv, start_cell, goal_index) -> bool:
        cfg = self.config
        if cfg.navfn or cfg.use_dijkstra:
            seed_idx, seed_val, push_idx = self._seeds(su, sv, start_cell, cost, width)
            return expansion_kernels.dijkstra_expand(cost, pot, width, seed_idx, seed_val, push_idx,
                                           goal_index, self._threshold0, 2.0 * self._neutral,
                                           cfg.use_quadratic)
        start_index = self._index(start_cell, width)
        return expansion_kernels.astar_expand(cost, pot, width, start_index, goal_index,
                                    np.float32(self._neutral), cfg.use_quadratic)

    def _seeds(self, su, sv, start_cell, cost, width):
        """Initial potentials and pushes of the wavefront.

        Precise start: the 3 x 3 lattice nodes around the node nearest the start point get
        neutral_cost x their distance to it (blocked nodes excepted), and the ring around them
        is pushed. ROS 1 seeds only the 2 x 2 nodes up and right of the point with
        ``2 neutral dx dy``-style products, which gives three of them 0 when the start is on a
        cell centre; its paths then wander around the start, and even with true distances a
        one-sided block bends straight paths near the start.
        """
        if not self._precise:
            k = self._index(start_cell, width)
            return (np.array([k], np.int64), np.array([0.0], np.float32),
                    np.array([k + 1, k - 1, k - width, k + width], np.int64))
        height = len(cost) // width
        cx, cy = int(round(su)), int(round(sv))
        seed_idx, seed_val, push = [], [], []
        for ox in range(-2, 3):
            for oy in range(-2, 3):
                x, y = cx + ox, cy + oy
                if not (0 <= x < width - 2 and 0 <= y < height - 2):
                    continue
                n = (y + 1) * width + x + 1
                if max(abs(ox), abs(oy)) == 2:
                    push.append(n)
                elif (ox == 0 and oy == 0) or not math.isinf(cost[n]):
                    seed_idx.append(n)
                    seed_val.append(self._neutral * math.hypot(x - su, y - sv))
        return (np.array(seed_idx, np.int64), np.array(seed_val, np.float32),
                np.array(push, np.int64))

    def _target(self, costmap, potential, goal_xy, goal_cell, reached, tol):
        """Where the plan ends: the goal, or the best reachable point within the tolerance."""
        gx, gy = goal_xy
        res = costmap.resolution
        if self.config.navfn:
            # navfn: points goal + (i, j) * resolution over the square [-tol, tol]^2.
            k = int(math.floor(2.0 * tol / res + 1e-9)) + 1
            offsets = -tol + res * np.arange(k)
            px, py = np.meshgrid(gx + offsets, gy + offsets)
            px, py = px.ravel(), py.ravel()
            mx, my, valid = costmap.world_to_map_array(px, py)
        else:
            if reached:
                return gx, gy
            if tol == 0.0:
                return None
            r = int(math.ceil(tol / res)) + 1
            gcx, gcy = goal_cell
            xs = np.arange(max(gcx - r, 0), min(gcx + r, costmap.size_x - 1) + 1)
            ys = np.arange(max(gcy - r, 0), min(gcy + r, costmap.size_y - 1) + 1)
            mx, my = (a.ravel() for a in np.meshgrid(xs, ys))
            px = costmap.origin_x + (mx + 0.5) * res
            py = costmap.origin_y + (my + 0.5) * res
            valid = np.hypot(px - gx, py - gy) <= tol
        d2 = (px - gx) ** 2 + (py - gy) ** 2
        ok = valid.copy()
        ok[valid] = potential[my[valid], mx[valid]] < POT_HIGH
        if not ok.any():
            return None
        best = np.flatnonzero(ok)[np.argmin(d2[ok])]
        return float(px[best]), float(py[best])

    def _measure(self, costmap: Costmap2D, xy: np.ndarray) -> tuple[float, float]:
        seg = np.diff(xy, axis=0)
        lengths = np.hypot(seg[:, 0], seg[:, 1])
        mid = xy[:-1] + 0.5 * seg
        mx, my, _ = costmap.world_to_map_array(mid[:, 0], mid[:, 1])
        mx = np.clip(mx, 0, costmap.size_x - 1)
        my = np.clip(my, 0, costmap.size_y - 1)
        step = self._metric_costs[costmap.costmap[my, mx]]
        return float(lengths.sum()), float((step * lengths).sum() / costmap.resolution)

    # -- helpers -----------------------------------------------------------------------------
    def _lattice(self, costmap: Costmap2D, wx: float, wy: float) -> tuple[float, float]:
        """World point -> potential-lattice coordinates (integer = cell centre), on the map."""
        u = (wx - costmap.origin_x) / costmap.resolution - self._offset
        v = (wy - costmap.origin_y) / costmap.resolution - self._offset
        return (min(max(u, 0.0), costmap.size_x - 1.0), min(max(v, 0.0), costmap.size_y - 1.0))

    @staticmethod
    def _index(cell, width: int) -> int:
        return (cell[1] + 1) * width + cell[0] + 1

    @staticmethod
    def _fail(reason: PlanFailure, message: str, potential=None) -> PlanResult:
        return PlanResult(False, np.empty((0, 3)), reason, message, potential)


_EXTRACTION_ERRORS = {1: "it ran off the map border", 2: "it ran into unassigned potential",
                      3: "it is stuck in a local minimum of the potential",
                      4: "step limit reached"}


def make_global_planner(type_name: str, params: dict | None = None) -> GlobalPlanner:
    """The planner selected by move_base's ``base_global_planner``, from its parameter dict."""
    if type_name == GLOBAL_PLANNER:
        return GlobalPlanner(GlobalPlannerConfig.from_params(params))
    if type_name == NAVFN:
        return GlobalPlanner(GlobalPlannerConfig.from_navfn_params(params))
    raise ValueError(f"unknown base_global_planner type {type_name!r}; "
                     f"supported: {GLOBAL_PLANNER}, {NAVFN}")


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel by planning on a tiny map."""
    costmap = Costmap2D(8, 8, 1.0, 0.0, 0.0)
    for params in ({}, {"use_dijkstra": False}, {"use_grid_path": True}):
        make_global_planner(GLOBAL_PLANNER, params).make_plan(costmap, (1.5, 1.5, 0.0),
                                                              (6.5, 6.5, 0.0))
