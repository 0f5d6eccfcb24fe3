"""A robot driven without move_base: a route planned on the world's exported map and a pure-pursuit follower, for
benches and tests that need the robot to move through a world the same way every run (bench/tracking_truth.py)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.inflation_layer import InflationLayer
from simplebot_navigation.planning import GLOBAL_PLANNER, make_global_planner
from simplebot_navigation.sim.map_export import export_map
from simplebot_navigation.sim.world import Pose2D, World

ROUTE_RESOLUTION = 0.05
#: the route keeps this much beyond the robot's inscribed radius out of lethal space, and its costs fall off
#: over INFLATION_M at a cost scaling factor (1/m), so it runs down the middle of doors and passages
ROUTE_MARGIN = 0.05
INFLATION_M = 1.0
#: the follower takes the route at points this far apart along it
ROUTE_STEP_M = 0.1


def planned_route(world: World, goals: list[Pose2D], inscribed_radius: float,
                  cost_scaling: float = 4.0) -> list[np.ndarray]:
    """One leg of (N, 2) points from the world's start to the first goal, and from each goal to the next, planned
    by global_planner on the world's static obstacles inflated for a robot of `inscribed_radius` (the inflation's
    cost_scaling_factor: `cost_scaling`). ValueError if a leg has no path."""
    costmap = _route_costmap(world, inscribed_radius, cost_scaling)
    planner = make_global_planner(GLOBAL_PLANNER, {"allow_unknown": False})
    legs, here = [], (world.start.x, world.start.y, world.start.yaw)
    for goal in goals:
        there = (goal.x, goal.y, goal.yaw)
        result = planner.make_plan(costmap, here, there)
        if not result.ok:
            raise ValueError(f"{world.name}: no route to {goal.name or there}: {result.message}")
        legs.append(result.poses[:, :2])
        here = there
    return legs


def _route_costmap(world: World, inscribed_radius: float, cost_scaling: float) -> Costmap2D:
    grid = export_map(world, ROUTE_RESOLUTION)
    ox, oy, _ = grid.origin
    costmap = Costmap2D(grid.width, grid.height, grid.resolution, ox, oy)
    costmap.costmap[grid.data == 100] = LETHAL_OBSTACLE
    costmap.costmap[grid.data < 0] = NO_INFORMATION
    layer = InflationLayer("inflation_layer", inflation_radius=inscribed_radius + INFLATION_M,
                           cost_scaling_factor=cost_scaling)
    layer.layered_costmap = SimpleNamespace(costmap=costmap, inscribed_radius=inscribed_radius + ROUTE_MARGIN)
    layer.on_initialize()
    layer.on_footprint_changed()
    layer.update_costs(costmap, 0, 0, costmap.size_x, costmap.size_y)
    return costmap


def resampled(route: np.ndarray, step: float = ROUTE_STEP_M) -> np.ndarray:
    """The polyline through `route` at points `step` apart along it (its ends kept)."""
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(route, axis=0).T))])
    at = np.append(np.arange(0.0, along[-1], step), along[-1])
    return np.column_stack([np.interp(at, along, route[:, 0]), np.interp(at, along, route[:, 1])])


class PathFollower:
    """Pure pursuit along legs of a route, one after the other, at `speed`: it steers towards the point
    `lookahead` ahead along the leg, slows down as the heading error grows and turns on the spot beyond
    TURN_ON_SPOT_RAD (keeping the side it began turning to); a leg is done within `tolerance` of its end."""

    TURN_ON_SPOT_RAD = 0.6
    STEER_GAIN = 5.0

    def __init__(self, legs: list[np.ndarray], speed: float, max_turn_rate: float = 2.0, tolerance: float = 0.3):
        legs = [np.asarray(leg, dtype=float) for leg in legs]
        if not legs or any(leg.ndim != 2 or leg.shape[1] != 2 or len(leg) < 2 for leg in legs):
            raise ValueError(f"a route is legs of (N >= 2, 2) points, got shapes {[leg.shape for leg in legs]}")
        if not (math.isfinite(speed) and speed > 0):
            raise ValueError(f"speed must be a positive number of m/s, got {speed!r}")
        self.legs, self.speed = [resampled(leg) for leg in legs], float(speed)
        self.lookahead = max(0.5, 0.35 * speed)
        self.max_turn_rate, self.tolerance = max_turn_rate, tolerance
        self.leg = self.index = 0
        self.turning = 0.0          # the side of a turn on the spot under way (+1, -1; 0: none)

    @property
    def done(self) -> bool:
        return self.leg == len(self.legs)

    def command(self, x: float, y: float, yaw: float) -> tuple[float, float]:
        """(v, w) for the robot at (x, y, yaw)."""
        here = np.array([x, y])
        while not self.done and np.hypot(*(self.legs[self.leg][-1] - here)) < self.tolerance:
            self.leg, self.index = self.leg + 1, 0
        if self.done:
            return 0.0, 0.0
        route = self.legs[self.leg][self.index:]
        self.index += int(np.argmin(np.hypot(*(route - here).T)))
        route = self.legs[self.leg][self.index:]
        beyond = np.flatnonzero(np.hypot(*(route - here).T) >= self.lookahead)
        target = route[beyond[0]] if len(beyond) else route[-1]
        error = math.remainder(math.atan2(target[1] - y, target[0] - x) - yaw, math.tau)
        if abs(error) < self.TURN_ON_SPOT_RAD:
            self.turning = 0.0
        elif not self.turning:
            self.turning = math.copysign(1.0, error)
        steer = self.turning * self.max_turn_rate if self.turning else self.STEER_GAIN * error
        w = max(-self.max_turn_rate, min(self.max_turn_rate, steer))
        return self.speed * max(0.0, 1.0 - abs(error) / self.TURN_ON_SPOT_RAD), w
