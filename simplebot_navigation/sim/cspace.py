"""Configuration-space analysis of a world for a disc-shaped robot, on a grid.

The obstacles are rasterised, a Euclidean distance transform gives every cell's clearance, and the
robot's centre may stand on cells whose clearance exceeds its radius plus a safety margin. From that
come the checks a generated world must pass (start and goal free and connected) and the two numbers
that say how hard it is: the bottleneck of the widest start-goal path, and how much longer than the
straight line the shortest C-space path is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from simplebot_navigation.geometry import inverse_transform_points
from simplebot_navigation.sim.world import Cylinder, Pose2D, World

DEFAULT_RESOLUTION = 0.025
DEFAULT_MARGIN = 0.05
_FOUR_CONNECTED = ndimage.generate_binary_structure(2, 1)


@dataclass(frozen=True)
class CSpaceMetrics:
    """How hard the drive from the start to one goal is for a disc of ``inflation`` = radius + margin.

    ``narrowest_passage`` is the free width between obstacle surfaces at the bottleneck of the widest
    path (twice the best path's minimum clearance, the start's and the goal's own clearance
    included); ``tortuosity`` is the shortest C-space path over the straight line. Both are
    measured on the grid: the width to about one ``resolution``, the length to about 2 %.
    """

    inflation: float
    resolution: float
    narrowest_passage: float
    path_length: float
    straight_line: float

    @property
    def tortuosity(self) -> float:
        return self.path_length / self.straight_line


class _Grid:
    """Cell centres over the world's bounds, and the clearance of each cell."""

    def __init__(self, world: World, resolution: float):
        x0, y0, x1, y1 = world.bounds()
        self.origin = (x0, y0)
        self.resolution = resolution
        self.shape = (int(math.ceil((y1 - y0) / resolution)), int(math.ceil((x1 - x0) / resolution)))
        occupied = np.zeros(self.shape, dtype=bool)
        for _, shape in world.obstacles():
            self._rasterise(shape, occupied)
        self.occupied = occupied
        # Distance from each cell centre to the nearest occupied centre, which lies up to half a
        # cell inside the obstacle's surface.
        self.clearance = ndimage.distance_transform_edt(~occupied) * resolution - resolution / 2

    def cell(self, pose: Pose2D) -> tuple[int, int]:
        row = int((pose.y - self.origin[1]) / self.resolution)
        col = int((pose.x - self.origin[0]) / self.resolution)
        return min(max(row, 0), self.shape[0] - 1), min(max(col, 0), self.shape[1] - 1)

    def _rasterise(self, shape, occupied: np.ndarray) -> None:
        cx, cy = shape.center
        if isinstance(shape, Cylinder):
            ex = ey = shape.radius
        else:
            c, s = abs(math.cos(shape.yaw)), abs(math.sin(shape.yaw))
            ex, ey = c * shape.size[0] / 2 + s * shape.size[1] / 2, s * shape.size[0] / 2 + c * shape.size[1] / 2
        r0, c0 = self.cell(Pose2D(cx - ex, cy - ey))
        r1, c1 = self.cell(Pose2D(cx + ex, cy + ey))
        rows, cols = np.mgrid[r0:r1 + 1, c0:c1 + 1]
        centres = np.stack([self.origin[0] + (cols + 0.5) * self.resolution,
                            self.origin[1] + (rows + 0.5) * self.resolution], axis=-1)
        if isinstance(shape, Cylinder):
            inside = np.hypot(centres[..., 0] - cx, centres[..., 1] - cy) <= shape.radius
        else:
            local = np.abs(inverse_transform_points((cx, cy, shape.yaw), centres))
            inside = (local[..., 0] <= shape.size[0] / 2) & (local[..., 1] <= shape.size[1] / 2)
        occupied[r0:r1 + 1, c0:c1 + 1] |= inside


def occupancy(world: World, resolution: float = DEFAULT_RESOLUTION) -> tuple[np.ndarray, tuple]:
    """(occupied, origin): the cells (rows = y) whose centre lies inside a static obstacle, and the (x, y) of cell
    (0, 0)'s corner."""
    grid = _Grid(world, resolution)
    return grid.occupied, grid.origin


def static_free(world: World, inflation: float, resolution: float = DEFAULT_RESOLUTION) -> tuple[np.ndarray, tuple]:
    """(free, origin): the cells (rows = y) where a disc's centre stays more than ``inflation`` from every static
    obstacle, and the (x, y) of cell (0, 0)'s corner."""
    grid = _Grid(world, resolution)
    return grid.clearance > inflation, grid.origin


def analyse(world: World, robot_radius: float, goal: Pose2D | None = None, margin: float = DEFAULT_MARGIN,
            resolution: float = DEFAULT_RESOLUTION) -> CSpaceMetrics:
    """Difficulty of the drive from the world's start to ``goal`` (default: its first goal).

    ValueError naming ``world.source`` if the start or the goal is blocked for a disc of
    robot_radius + margin, or if no C-space path connects them.
    """
    goal = goal or world.goals[0]
    inflation = robot_radius + margin
    grid = _Grid(world, resolution)
    free = grid.clearance > inflation
    unsolvable = f"{world.source}: unsolvable for a robot of radius {robot_radius} m plus a {margin} m margin"
    start_cell, goal_cell = grid.cell(world.start), grid.cell(goal)
    for what, pose, cell in (("start", world.start, start_cell), ("goal", goal, goal_cell)):
        if not free[cell]:
            distance, label = world.nearest_obstacle(pose.x, pose.y)
            raise ValueError(f"{unsolvable}: the {what} ({pose.x:g}, {pose.y:g}) is blocked, "
                             f"{distance:.3f} m from {label}")
    labels, _ = ndimage.label(free, structure=_FOUR_CONNECTED)
    if labels[start_cell] != labels[goal_cell]:
        raise ValueError(f"{unsolvable}: no C-space path connects the start ({world.start.x:g}, {world.start.y:g}) "
                         f"to the goal ({goal.x:g}, {goal.y:g}); some passage is narrower than "
                         f"{2 * inflation:.2f} m")
    straight = math.hypot(goal.x - world.start.x, goal.y - world.start.y)
    return CSpaceMetrics(inflation, resolution, 2 * _widest_path_clearance(grid, start_cell, goal_cell, inflation),
                         _shortest_path(free, start_cell, goal_cell) * resolution, straight)


def _widest_path_clearance(grid: _Grid, start: tuple, goal: tuple, known: float) -> float:
    """The largest clearance t such that cells with clearance >= t still connect start and goal.

    Binary search over the distinct clearance values (the transform has few), one labelling per step.
    """
    values = np.unique(grid.clearance[grid.clearance > known])
    lo = 0
    hi = int(np.searchsorted(values, min(grid.clearance[start], grid.clearance[goal]), side="right")) - 1
    best = known
    while lo <= hi:
        mid = (lo + hi) // 2
        labels, _ = ndimage.label(grid.clearance >= values[mid], structure=_FOUR_CONNECTED)
        if labels[start] and labels[start] == labels[goal]:
            best, lo = float(values[mid]), mid + 1
        else:
            hi = mid - 1
    return best


def _shortest_path(free: np.ndarray, start: tuple, goal: tuple) -> float:
    """Length in cells of the shortest 16-connected path over free cells (Dijkstra on the grid graph).

    Knight moves, allowed when both cells they cut through are free, keep a straight line in any
    direction within about 3 % of its length (8-connected moves are up to 8 % long). Cells are
    numbered on the grid padded by two blocked cells, so no move wraps around an edge.
    """
    padded = np.pad(free, 2)
    width = padded.shape[1]
    flat = padded.ravel()
    cells = np.flatnonzero(flat)
    rows, cols, weights = [], [], []
    for (di, dj), crossed in _MOVES:
        allowed = flat[cells + di * width + dj]
        for ci, cj in crossed:
            allowed &= flat[cells + ci * width + cj]
        tails = cells[allowed]
        heads = tails + di * width + dj
        rows += [tails, heads]
        cols += [heads, tails]
        weights.append(np.full(2 * len(tails), math.hypot(di, dj)))
    graph = coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(flat.size, flat.size))
    source, target = ((r + 2) * width + c + 2 for r, c in (start, goal))
    return float(dijkstra(graph.tocsr(), indices=source)[target])


# Half of the 16 moves, each with the cells a knight move cuts through (the edges go both ways).
_MOVES = (((0, 1), ()), ((1, 0), ()), ((1, 1), ()), ((1, -1), ()),
          ((1, 2), ((0, 1), (1, 1))), ((2, 1), ((1, 0), (1, 1))),
          ((1, -2), ((0, -1), (1, -1))), ((2, -1), ((1, 0), (1, -1))))
