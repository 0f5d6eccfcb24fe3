"""The space-time guide of the MPPI controller: which gap to take among the moving obstacles, and when.

A sampling controller sees three seconds ahead and scores each rollout on its own; among a crowd it stops in front
of a gap that opens a second later, or slips into one that closes. Every guide_period the guide runs the
space-time wavefront (planning/space_time.py) on a grid around the robot, in steps of guide_step (0.2 s): the local costmap's inscribed cells are
static walls, the moving obstacles' predicted keep-out circles (grown by guide_radius_growth per second ahead)
close cells step by step, and the robot moves at guide_speed_share x vx_max. Where those margins close the ways
ahead (a corridor to an oncoming person), the search runs again without them. Of the places reachable at the
horizon it takes the one with the least way left along the global plan, and traces back how to be there; the
rollouts are then scored against where that path is at each of their times (kernels.guide_terms), so the
controller waits where the path waits and goes where it goes.

Only while moving obstacles are within reach of the horizon: without them the plan ahead is the guide.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from simplebot_navigation.mppi import kernels
from simplebot_navigation.mppi.config import MppiConfig
from simplebot_navigation.perception.prediction import MotionPrediction
from simplebot_navigation.planning.space_time import STEP_CELLS, MovingDiscs, SpaceTimePath, SpaceTimeSearch

#: the grid reaches this far (m) beyond the horizon's travel around the robot
GRID_MARGIN_M = 1.0
#: a path with the margins that makes less than this share of the progress the horizon allows is planned again
#: without them, and that one taken if it gets further
SLOW_SHARE = 0.25


class SpaceTimeGuide:
    """Plans the guide; one instance per controller."""

    def __init__(self, cfg: MppiConfig):
        self.cfg = cfg

    def half_width(self) -> float:
        """Half the side of the square grid the search runs on (m)."""
        guide = self.cfg.space_time
        return self.speed() * guide.guide_horizon + GRID_MARGIN_M

    def speed(self) -> float:
        return self.cfg.limits.vx_max * self.cfg.space_time.guide_speed_share

    def plan(self, state: np.ndarray, plan_xy: np.ndarray, costmap, obstacles: np.ndarray,
             prediction: MotionPrediction, reach: float) -> SpaceTimePath | None:
        """The path from the robot's position at time 0, in the costmap's frame, or None (no moving obstacle near,
        or the search found nothing). ``plan_xy`` (N, 2): the global plan from the robot's closest point on;
        ``obstacles`` (K, 7) prediction rows; ``reach``: the body's radius about its centre (m)."""
        guide = self.cfg.space_time
        half = self.half_width()
        if len(plan_xy) == 0 or not _near(obstacles, state[:2], half + guide.guide_horizon * _speeds(obstacles)):
            return None
        cell = self.speed() * guide.guide_step / STEP_CELLS
        search = SpaceTimeSearch(*_static_free(costmap, state[:2], half, cell))
        cost = way_left(plan_xy)

        def search_with(growth: float, clearance: float) -> SpaceTimePath | None:
            def discs_at(t: float) -> MovingDiscs:
                radii = prediction.radii(obstacles, [t])[:, 0] + reach + growth * t
                return MovingDiscs(prediction.centres(obstacles, [t])[:, 0], radii, _speeds(obstacles))
            return search.path(tuple(state[:2]), cost, self.speed(), discs_at, 0.0, guide.guide_horizon, clearance)

        found = search_with(guide.guide_radius_growth, guide.guide_clearance)
        if guide.guide_radius_growth == 0 and guide.guide_clearance == 0:
            return found
        start = cost(state[None, :2])[0]
        progress = -math.inf if found is None or not found.full else start - cost(found.xy[-1:])[0]
        if progress < SLOW_SHARE * self.speed() * guide.guide_horizon:
            # the margins closed the ways ahead (a corridor to an oncoming person): without them, if that goes on
            bare = search_with(0.0, 0.0)
            if bare is not None and bare.full and start - cost(bare.xy[-1:])[0] > progress:
                found = bare
        return found


def way_left(plan_xy: np.ndarray):
    """The guide's cost to go from points (n, 2): the straight line to the end of the plan ahead. Lateral offset
    from the plan costs next to nothing, so the search may step far aside for a crowd's gap (a cost measured from
    the nearest plan point, 1:1 or 0.25:1 against the way along it, lost 2-4 of 42 crowd runs, BENCHMARKS.md);
    a plan ahead that bends back towards the robot is the case it misjudges."""
    end = np.asarray(plan_xy, dtype=float)[-1]

    def cost(xy: np.ndarray) -> np.ndarray:
        return np.hypot(xy[:, 0] - end[0], xy[:, 1] - end[1])
    return cost


def _speeds(obstacles: np.ndarray) -> np.ndarray:
    return np.hypot(obstacles[:, 2], obstacles[:, 3])


def _near(obstacles: np.ndarray, centre: np.ndarray, within: np.ndarray) -> bool:
    return bool((np.hypot(*(obstacles[:, :2] - centre).T) < within).any())


def _static_free(costmap, centre: np.ndarray, half: float, resolution: float
                 ) -> tuple[np.ndarray, tuple[float, float], float]:
    """The search's grid around ``centre``: (free, origin, resolution). A cell is blocked if any costmap cell
    within it is inscribed or lethal; outside the local costmap every cell is free (its rolling window knows
    nothing there, and the global plan went around the walls)."""
    n = int(math.ceil(2 * half / resolution))
    origin = (float(centre[0] - 0.5 * n * resolution), float(centre[1] - 0.5 * n * resolution))
    grid, fine = costmap.costmap, costmap.resolution
    walls = (grid == kernels.INSCRIBED) | (grid == kernels.LETHAL)
    size = max(1, int(math.ceil(resolution / fine)) + 1)
    walls = ndimage.maximum_filter(walls, size=size, mode="constant", cval=False)
    centres = origin[0] + (np.arange(n) + 0.5) * resolution, origin[1] + (np.arange(n) + 0.5) * resolution
    cols = np.floor((centres[0] - costmap.origin_x) / fine).astype(int)
    rows = np.floor((centres[1] - costmap.origin_y) / fine).astype(int)
    col_in, row_in = (cols >= 0) & (cols < grid.shape[1]), (rows >= 0) & (rows < grid.shape[0])
    free = np.ones((n, n), dtype=bool)
    inside = np.ix_(row_in, col_in)
    free[inside] = ~walls[np.ix_(rows[row_in], cols[col_in])]
    return free, origin, resolution
