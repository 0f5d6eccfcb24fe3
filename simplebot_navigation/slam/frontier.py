"""Frontier-based exploration as ROS's explore_lite does it: drive to the edge between the known free space and the
unknown, the cheapest such edge first, and give up on goals the robot cannot reach.

explore_lite's rules kept here: a frontier cell is an unknown cell with at least one free 4-neighbour; frontiers are
8-connected groups of them; a frontier shorter than ``min_frontier_size`` (cells * resolution) is ignored;
``cost = potential_scale * distance - gain_scale * size`` (both in metres) and the cheapest wins; a goal that fails,
or towards which the robot makes no progress for ``progress_timeout`` seconds, is blacklisted.

What differs, and why:
- Cell values: negative is unknown, 0..FREE_MAX free, anything above FREE_MAX an obstacle (a cell the mapper is
  unsure of is kept clear of like a certain wall).
- ``distance`` is the travel distance over free cells the robot fits through (8-connected moves, no cutting
  corners), not explore_lite's straight line, which prefers a frontier on the other side of a wall.
- A free cell is one the robot fits on when its centre is at least ``clearance`` from the nearest edge of an
  obstacle cell (exact along rows and columns). A straight gap narrower than ``2 * clearance`` is never passed;
  a gap of an even number of cells needs one cell more, as the robot stands on cell centres.
- Near the robot (within ``clearance`` + one cell) a free cell also counts when it is at least as clear as the
  robot's own cell, and the robot's cell always counts: a robot that ended up hugging a wall can leave it by
  moving away from it. This reaches only that far, so a too narrow gap is passed only by a robot already in it
  or right at it.
- The goal is the reachable cell 8-adjacent to the frontier nearest its centroid (explore_lite sends the centroid
  itself, which may lie in unknown space or in a wall).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from simplebot_navigation.maps.map_io import OccupancyMap

#: the highest cell value read as free: map_saver's free threshold, 0.25
FREE_MAX = 25
#: the most cells a grid may have (4000 x 4000: a 200 m square at 5 cm); the travel graph of a 16 M cell map
#: already takes about a gigabyte
MAX_CELLS = 16_000_000
#: the largest clearance (metres): twice any mobile base's radius; more shuts every door of a building
MAX_CLEARANCE = 5.0
#: how much shorter (metres of travel) the way to the goal must get to count as progress: less is localisation
#: jitter, which explore_lite (any decrease counts) mistakes for progress forever. On a map coarser than 6.7 cm it
#: is 1.5 cells instead, as a robot wobbling across a cell border shortens the way by a cell (a diagonal: 1.41)
MIN_PROGRESS = 0.1
#: slack in the size and clearance comparisons, far below a cell, so that a size of exactly 10 * 0.05 passes 0.5
_EPS = 1e-9
_EIGHT = np.ones((3, 3), dtype=bool)
#: (row, col) steps to the 8 neighbours, the 4 straight ones first
_STEPS = ((0, 1), (1, 0), (0, -1), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))


@dataclass(frozen=True)
class Frontier:
    """One frontier: how long it is, where it lies, where to send the robot and what that costs. ``distance`` runs
    from the centre of the robot's cell to the goal's, and is inf never: unreachable frontiers are left out."""
    cells: int
    size: float
    centroid: tuple[float, float]
    goal: tuple[float, float]
    distance: float
    cost: float


def find_frontiers(grid: OccupancyMap, robot_xy, min_frontier_size: float = 0.5, potential_scale: float = 3.0,
                   gain_scale: float = 1.0, clearance: float = 0.3) -> list[Frontier]:
    """The frontiers the robot at ``robot_xy`` (map frame, metres) can reach, cheapest first (module docstring)."""
    min_frontier_size = _number("min_frontier_size", min_frontier_size)
    potential_scale = _number("potential_scale", potential_scale)
    gain_scale = _number("gain_scale", gain_scale)
    clearance = _number("clearance", clearance, positive=True, high=MAX_CLEARANCE)
    data, resolution, (origin_x, origin_y) = _checked_grid(grid)
    robot = _robot_cell(robot_xy, data.shape, resolution, origin_x, origin_y)
    free = (data >= 0) & (data <= FREE_MAX)
    travel = _travel_distances(free, data > FREE_MAX, robot, resolution, clearance)
    labels, count = ndimage.label((data < 0) & ndimage.binary_dilation(free), structure=_EIGHT)
    if count == 0:
        return []
    rows, cols = np.nonzero(labels)
    which = labels[rows, cols]
    cells = np.bincount(which, minlength=count + 1)[1:]
    centroids = np.stack([np.bincount(which, rows, count + 1)[1:], np.bincount(which, cols, count + 1)[1:]],
                         axis=1) / cells[:, None]
    goals = _goal_cells(labels, count, travel, centroids)
    frontiers = []
    for k in np.flatnonzero((goals >= 0) & (cells * resolution >= min_frontier_size - _EPS)):
        goal_row, goal_col = divmod(int(goals[k]), data.shape[1])
        size, distance = float(cells[k] * resolution), float(travel[goal_row, goal_col])
        frontiers.append(Frontier(
            int(cells[k]), size,
            (float(origin_x + (centroids[k, 1] + 0.5) * resolution),
             float(origin_y + (centroids[k, 0] + 0.5) * resolution)),
            (origin_x + (goal_col + 0.5) * resolution, origin_y + (goal_row + 0.5) * resolution),
            distance, potential_scale * distance - gain_scale * size))
    return sorted(frontiers, key=lambda f: f.cost)       # stable: ties keep the map's row order


class Explorer:
    """Chooses the next exploration goal, remembers goals that failed (blacklist radius) and gives up on a goal
    whose frontier has not changed and towards which the robot made no progress for progress_timeout seconds.

    Bounds: min_frontier_size, potential_scale, gain_scale and blacklist_radius >= 0; clearance in
    (0, MAX_CLEARANCE]; progress_timeout > 0 seconds; all finite."""

    def __init__(self, min_frontier_size: float = 0.5, potential_scale: float = 3.0, gain_scale: float = 1.0,
                 clearance: float = 0.3, progress_timeout: float = 30.0, blacklist_radius: float = 0.5):
        self.min_frontier_size = _number("min_frontier_size", min_frontier_size)
        self.potential_scale = _number("potential_scale", potential_scale)
        self.gain_scale = _number("gain_scale", gain_scale)
        self.clearance = _number("clearance", clearance, positive=True, high=MAX_CLEARANCE)
        self.progress_timeout = _number("progress_timeout", progress_timeout, positive=True)
        self.blacklist_radius = _number("blacklist_radius", blacklist_radius)
        self._blacklist: list[tuple[float, float]] = []
        self._goal: tuple[float, float] | None = None
        self._best_distance = math.inf      # the shortest way to the goal seen since it was chosen
        self._last_progress = 0.0           # when that way last got MIN_PROGRESS shorter (or the goal was chosen)

    @property
    def blacklist(self) -> tuple[tuple[float, float], ...]:
        return tuple(self._blacklist)

    def next_goal(self, grid: OccupancyMap, robot_xy, now: float) -> tuple[float, float] | None:
        """Where to drive now (None: nothing left to explore). The same goal comes back while its frontier stays
        the cheapest and unchanged (its goal the same cell), so a caller re-sends only when the goal changes, as
        explore_lite does. That goal is blacklisted, and the next one chosen, once ``progress_timeout`` seconds
        pass in which the travel distance to it never got MIN_PROGRESS (or 1.5 cells) shorter than its best; a
        clock that goes back (a simulation restarted) restarts the wait."""
        now = _number("now", now, low=-math.inf)
        frontiers = [f for f in find_frontiers(grid, robot_xy, self.min_frontier_size, self.potential_scale,
                                               self.gain_scale, self.clearance) if not self._blacklisted(f.goal)]
        if not frontiers:
            self._goal = None
            return None
        best = frontiers[0]
        if self._goal is None or math.dist(best.goal, self._goal) >= grid.resolution / 2 or now < self._last_progress:
            return self._choose(best, now)
        if self._best_distance - best.distance >= max(MIN_PROGRESS, 1.5 * grid.resolution) - _EPS:
            self._best_distance, self._last_progress = best.distance, now
        elif now - self._last_progress >= self.progress_timeout:
            self._blacklist.append(self._goal)
            rest = [f for f in frontiers[1:] if not self._blacklisted(f.goal)]
            if not rest:
                self._goal = None
                return None
            return self._choose(rest[0], now)
        return self._goal

    def goal_failed(self, goal) -> None:
        """The goal could not be reached (e.g. move_base aborted): blacklist it, and choose afresh next time."""
        point = _point("goal", goal)
        self._blacklist.append(point)
        if self._goal is not None and math.dist(point, self._goal) <= self.blacklist_radius:
            self._goal = None

    def _choose(self, frontier: Frontier, now: float) -> tuple[float, float]:
        self._goal, self._best_distance, self._last_progress = frontier.goal, frontier.distance, now
        return frontier.goal

    def _blacklisted(self, goal: tuple[float, float]) -> bool:
        return any(math.dist(goal, bad) <= self.blacklist_radius for bad in self._blacklist)


# -- where the robot goes for a frontier ---------------------------------------------------------------
#: Where a frontier's goal is sent (goal_to_send). The goal lies next to the unknown, often in a doorway, by a wall's
#: end or by a desk that a SLAM map does not show yet (slam marks a cell occupied after two returns and free after
#: four misses), while move_base's costmap holds every return and its global planner cannot plan to a goal in its
#: inscribed band. So the robot is sent GOAL_MARGIN (m) clearer than ``clearance`` of the unknown, to a cell
#: TURN_CLEARANCE (m) clear of the obstacles that sees the goal, up to VIEW_SHIFT (m) back (the lidars reach 5.6 m).
#: A box robot (circumscribed radius 0.54 m) driven into a nook may not get out: TEB left it in a 1.2 x 1.7 m nook
#: of the office's east room, between a table, a shelf and two walls, where it could just turn (0.6 m)
GOAL_MARGIN = 0.1
TURN_CLEARANCE = 0.75
VIEW_SHIFT = 2.0


def goal_to_send(grid: OccupancyMap, goal, clearance: float) -> tuple[float, float] | None:
    """Where to send the robot for the frontier whose goal is ``goal`` (a free cell of ``grid`` by the unknown): the
    cell nearest the goal within VIEW_SHIFT that sees it (no obstacle cell on the way), is TURN_CLEARANCE clear of the
    map's obstacles and GOAL_MARGIN clearer than ``clearance`` of the unknown, and is joined to the goal over cells
    ``clearance`` clear of the obstacles. None when no cell is: the frontier lies in a nook."""
    data, res, origin = _checked_grid(grid)
    goal = _point("goal", goal)
    clearance = _number("clearance", clearance, positive=True, high=MAX_CLEARANCE)
    rows, cols, distance = _window(data.shape, res, origin, goal, VIEW_SHIFT + TURN_CLEARANCE)
    row, col = (math.floor((goal[k] - origin[k]) / res) - start for k, start in ((1, rows.start), (0, cols.start)))
    if not (0 <= row < distance.shape[0] and 0 <= col < distance.shape[1]):
        return None
    cells = data[rows, cols]
    blocked = cells > FREE_MAX
    clear, clear_of_unknown = (ndimage.distance_transform_edt(~mask, sampling=res) - res / 2 if mask.any()
                               else np.full(cells.shape, np.inf) for mask in (blocked, cells < 0))
    labels, _ = ndimage.label((cells >= 0) & (clear >= clearance - _EPS))
    if not labels[row, col]:
        return None
    roomy = np.argwhere((labels == labels[row, col]) & (clear_of_unknown >= clearance + GOAL_MARGIN - _EPS)
                        & (clear >= TURN_CLEARANCE - _EPS) & (distance <= VIEW_SHIFT))
    for r, c in roomy[np.argsort(distance[roomy[:, 0], roomy[:, 1]], kind="stable")]:
        steps = np.linspace(0.0, 1.0, 2 * max(abs(r - row), abs(c - col)) + 2)
        if not blocked[np.rint(r + steps * (row - r)).astype(int), np.rint(c + steps * (col - c)).astype(int)].any():
            return (float(origin[0] + (cols.start + c + 0.5) * res), float(origin[1] + (rows.start + r + 0.5) * res))
    return None


def footprint_cleared(grid: OccupancyMap, robot_xy, looked_from=(), clearance: float = 0.3) -> OccupancyMap:
    """The map as the robot's own presence shows it. The lidars never see under the robot, and a SLAM map marks a
    cell free only once several scans saw through it, so where the robot stood the map may keep an unknown patch: a
    frontier no drive resolves, and at the robot a patch that cuts its cell off from the free space round it. So an
    unknown patch round the robot, or round a place in ``looked_from`` (where it turned on the spot), that lies
    within 2 x ``clearance`` of it is free, and so is every unknown cell within ``clearance`` of the robot
    (costmap_2d clears the footprint too). The grid given is not changed."""
    data, res, origin = _checked_grid(grid)
    robot = _point("robot_xy", robot_xy)
    clearance = _number("clearance", clearance, positive=True, high=MAX_CLEARANCE)
    data = data.copy()
    for spot in (robot, *(_point("looked_from", spot) for spot in looked_from)):
        rows, cols, _ = _window(data.shape, res, origin, spot, 2.0 * clearance)
        labels, _ = ndimage.label(data[rows, cols] < 0)
        row, col = (math.floor((spot[k] - origin[k]) / res) for k in (1, 0))
        if not (rows.start <= row < rows.stop and cols.start <= col < cols.stop):
            continue                                    # off the map: nothing of it is under the robot
        patch = labels[row - rows.start, col - cols.start]
        border = np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])
        if patch and patch not in border:
            data[rows, cols][labels == patch] = 0
    rows, cols, distance = _window(data.shape, res, origin, robot, clearance)
    data[rows, cols][(distance <= clearance) & (data[rows, cols] < 0)] = 0
    return dataclasses.replace(grid, data=data)


def _window(shape: tuple[int, int], resolution: float, origin: tuple[float, float], centre: tuple[float, float],
            radius: float) -> tuple[slice, slice, np.ndarray]:
    """The grid's rows and columns within ``radius`` of ``centre`` (a square), and their cells' distances to it."""
    (height, width), (x0, y0) = shape, origin
    cols, rows = (slice(max(math.floor((at - radius - low) / resolution), 0),
                        max(min(math.ceil((at + radius - low) / resolution), n), 0))
                  for at, low, n in ((centre[0], x0, width), (centre[1], y0, height)))
    y, x = np.ogrid[rows, cols]
    return rows, cols, np.hypot(x0 + (x + 0.5) * resolution - centre[0], y0 + (y + 0.5) * resolution - centre[1])


# -- reachability --------------------------------------------------------------------------------
def _travel_distances(free: np.ndarray, blocked: np.ndarray, robot: tuple[int, int], resolution: float,
                      clearance: float) -> np.ndarray:
    """Metres of travel from the robot's cell to every cell (inf where it cannot go)."""
    allowed = _fitting_cells(free, blocked, robot, resolution, clearance)
    components, _ = ndimage.label(allowed)      # 4-connected: a diagonal move needs both straight ones free
    return _dijkstra(components == components[robot], robot, resolution)


def _fitting_cells(free: np.ndarray, blocked: np.ndarray, robot: tuple[int, int], resolution: float,
                   clearance: float) -> np.ndarray:
    """The cells the robot fits on, with the relaxation near the robot (module docstring)."""
    if blocked.any():
        clear = ndimage.distance_transform_edt(~blocked, sampling=resolution) - resolution / 2
    else:
        clear = np.full(free.shape, np.inf)
    allowed = free & (clear >= clearance - _EPS)
    reach = clearance / resolution + 1.0
    span = int(math.ceil(reach))
    row, col = robot
    window = (slice(max(row - span, 0), row + span + 1), slice(max(col - span, 0), col + span + 1))
    rows, cols = np.ogrid[window]
    near = (rows - row) ** 2 + (cols - col) ** 2 <= reach * reach
    floor = min(clearance, clear[robot])
    allowed[window] |= near & free[window] & (clear[window] >= floor - _EPS)
    allowed[robot] = True
    return allowed


def _dijkstra(inside: np.ndarray, robot: tuple[int, int], resolution: float) -> np.ndarray:
    """Shortest 8-connected travel (metres) from the robot over the cells ``inside``; a diagonal step needs both
    cells beside it inside, so the robot never cuts a wall's corner."""
    count = int(inside.sum())
    ids = np.full((inside.shape[0] + 2, inside.shape[1] + 2), -1, dtype=np.int32)      # a border of -1
    ids[1:-1, 1:-1][inside] = np.arange(count, dtype=np.int32)
    rows, cols = np.nonzero(inside)
    rows, cols = rows + 1, cols + 1
    targets = np.empty((count, len(_STEPS)), dtype=np.int32)
    for k, (dr, dc) in enumerate(_STEPS):
        targets[:, k] = ids[rows + dr, cols + dc]
        if dr and dc:
            targets[(ids[rows + dr, cols] < 0) | (ids[rows, cols + dc] < 0), k] = -1
    weights = np.broadcast_to(np.where([bool(dr and dc) for dr, dc in _STEPS], math.sqrt(2.0), 1.0) * resolution,
                              targets.shape)
    valid = targets >= 0
    indptr = np.concatenate([[0], np.cumsum(valid.sum(axis=1))])
    graph = sparse.csr_matrix((weights[valid], targets[valid], indptr), shape=(count, count))
    travel = np.full(inside.shape, np.inf)
    travel[inside] = csgraph.dijkstra(graph, indices=int(ids[robot[0] + 1, robot[1] + 1]))
    return travel


def _goal_cells(labels: np.ndarray, count: int, travel: np.ndarray, centroids: np.ndarray) -> np.ndarray:
    """For frontiers 1..count, the flat index of the reachable cell 8-adjacent to the frontier nearest its
    centroid (``centroids`` in (row, col) cells); -1 for a frontier no reachable cell touches."""
    height, width = labels.shape
    reachable = np.isfinite(travel)
    flat = np.arange(labels.size).reshape(labels.shape)
    found_label, found_cell = [], []
    for dr, dc in _STEPS:
        here = (slice(max(-dr, 0), height - max(dr, 0)), slice(max(-dc, 0), width - max(dc, 0)))
        there = (slice(max(dr, 0), height - max(-dr, 0)), slice(max(dc, 0), width - max(-dc, 0)))
        pair = reachable[here] & (labels[there] > 0)
        found_label.append(labels[there][pair])
        found_cell.append(flat[here][pair])
    label, cell = np.concatenate(found_label), np.concatenate(found_cell)
    goals = np.full(count, -1, dtype=np.int64)
    if len(cell) == 0:
        return goals
    row, col = np.divmod(cell, width)
    off_centre = (row - centroids[label - 1, 0]) ** 2 + (col - centroids[label - 1, 1]) ** 2
    order = np.lexsort((cell, off_centre, label))
    label, cell = label[order], cell[order]
    first = np.concatenate([[True], label[1:] != label[:-1]])
    goals[label[first] - 1] = cell[first]
    return goals


# -- input checks --------------------------------------------------------------------------------
def _number(name: str, value, low: float = 0.0, positive: bool = False, high: float = math.inf) -> float:
    """``value`` as a finite float in [low, high] (above low when ``positive``), else ValueError naming it."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value < low or (positive and value <= low) or value > high:
        bounds = " and ".join(([f"{'>' if positive else '>='} {low:g}"] if low > -math.inf else [])
                              + ([f"<= {high:g}"] if high < math.inf else []))
        raise ValueError(f"{name}: expected a finite number{' ' + bounds if bounds else ''}, got {value!r}")
    return value


def _point(name: str, value) -> tuple[float, float]:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (x, y) in metres, got {value!r}") from None
    if array.shape != (2,) or not np.isfinite(array).all():
        raise ValueError(f"{name}: expected two finite numbers (x, y) in metres, got {value!r}")
    return float(array[0]), float(array[1])


def _checked_grid(grid) -> tuple[np.ndarray, float, tuple[float, float]]:
    """The grid's cells, resolution and origin (x, y), once they are known to be usable."""
    if not isinstance(grid, OccupancyMap):
        raise ValueError(f"grid: expected an OccupancyMap, got {type(grid).__name__}")
    data = grid.data
    if not isinstance(data, np.ndarray) or data.dtype != np.int8 or data.ndim != 2 or data.size == 0:
        raise ValueError(f"grid.data: expected a non-empty 2-D int8 array, got {getattr(data, 'dtype', data)!r} "
                         f"of shape {np.shape(data)}")
    if data.size > MAX_CELLS:
        raise ValueError(f"grid.data: {data.shape[0]} x {data.shape[1]} cells, more than MAX_CELLS {MAX_CELLS}")
    resolution = _number("grid.resolution", grid.resolution, positive=True)
    try:
        origin = np.asarray(grid.origin, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"grid.origin: expected (x, y, yaw), got {grid.origin!r}") from None
    if origin.shape != (3,) or not np.isfinite(origin).all():
        raise ValueError(f"grid.origin: expected three finite numbers (x, y, yaw), got {grid.origin!r}")
    if origin[2] != 0.0:
        raise ValueError(f"grid.origin: yaw must be 0 (frontiers of a rotated map are not supported), "
                         f"got {origin[2]!r}")
    return data, resolution, (float(origin[0]), float(origin[1]))


def _robot_cell(robot_xy, shape: tuple[int, int], resolution: float, origin_x: float, origin_y: float
                ) -> tuple[int, int]:
    x, y = _point("robot_xy", robot_xy)
    col, row = math.floor((x - origin_x) / resolution), math.floor((y - origin_y) / resolution)
    if not (0 <= row < shape[0] and 0 <= col < shape[1]):
        raise ValueError(f"robot_xy: ({x:g}, {y:g}) lies outside the map (cell row {row}, col {col} of "
                         f"{shape[0]} x {shape[1]})")
    return row, col
