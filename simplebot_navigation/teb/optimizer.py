"""Sparse non-linear least squares over the TEB hyper-graph for a diff-drive robot (docs/reference.md §4.1).

Per outer iteration the band is resized, obstacles and via-points are associated with its poses
(the g2o graph of one buildGraph call), and the Levenberg-Marquardt inner loop runs as one
compiled call (teb/solver_kernels.py): every edge family is evaluated per edge, J^T J is accumulated
into banded storage and solved by banded Cholesky with g2o's damping rule. testing/teb_reference.py is
the numpy oracle of the same evaluation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from simplebot_navigation.teb import edge_kernels, solver_kernels
from simplebot_navigation.teb.band import TimedElasticBand
from simplebot_navigation.teb.obstacles import associate_obstacles, dynamic_obstacle_edges, motion_prediction


@dataclass
class EdgeSet:
    """Edges fixed for one outer iteration: obstacle and via-point edges (pose index and point),
    the clearance of the gap each obstacle edge's pose passes (inf: none) and the obstacle
    weight reached by this outer iteration; n is the band's number of time differences.
    Dynamic obstacle edges: pose index and the obstacle (x, y, radius) where it is predicted at
    that pose's time, with weight_dynamic_obstacle times the same multiplier."""
    obst_pose: np.ndarray
    obst_point: np.ndarray
    obst_gap: np.ndarray
    via_pose: np.ndarray
    via_point: np.ndarray
    obstacle_weight: float
    n: int = 0
    dyn_pose: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    dyn_obstacle: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    dynamic_weight: float = 0.0

    @property
    def arrays(self) -> tuple:
        """The edge set as the kernels take it."""
        return (np.ascontiguousarray(self.obst_pose, dtype=np.int64),
                np.ascontiguousarray(self.obst_point, dtype=float).reshape(-1, 2),
                np.ascontiguousarray(self.obst_gap, dtype=float),
                np.ascontiguousarray(self.via_pose, dtype=np.int64),
                np.ascontiguousarray(self.via_point, dtype=float).reshape(-1, 2),
                np.ascontiguousarray(self.dyn_pose, dtype=np.int64),
                np.ascontiguousarray(self.dyn_obstacle, dtype=float).reshape(-1, 3))


class RotType(IntEnum):
    """A preferred turning direction (oscillation recovery); the value is the sign of the rotation
    the prefer_rotdir edges let through."""
    none = 0
    left = 1
    right = -1


class TebOptimizer:
    """Optimises one band in place; keeps only the config, the footprint model and the preferred
    turning direction the oscillation recovery sets."""

    def __init__(self, cfg, model):
        self.cfg = cfg
        self.model = model
        self.start_velocity = (0.0, 0.0)
        self.free_goal_vel = False
        self.prefer_rotdir = RotType.none

    # -- outer loop -------------------------------------------------------------------------
    def optimize(self, band: TimedElasticBand, obstacles: np.ndarray, via_points: np.ndarray | None,
                 start_velocity, free_goal_vel: bool, compute_cost: bool = True,
                 outer_iterations: int | None = None, skip_outer: int = 0,
                 dynamic_obstacles: np.ndarray | None = None) -> float:
        """optimizeTEB: outer iterations of autoResize + association + inner LM, the obstacle
        weights growing by weight_adapt_factor. skip_outer leaves out the first outer iterations
        (a warm-started band then goes straight to the larger obstacle weights and its cost is
        taken at the same final weight as a full run). dynamic_obstacles: prediction rows
        (perception/prediction.py; planned_motion zeroes the velocities of those not to be predicted).
        Returns the selection cost of the final graph (inf unless compute_cost)."""
        trajectory, optim = self.cfg.trajectory, self.cfg.optim
        self.start_velocity = (float(start_velocity[0]), float(start_velocity[1]))
        self.free_goal_vel = free_goal_vel
        multiplier = optim.weight_adapt_factor ** skip_outer
        cost = math.inf
        outer_iterations = optim.no_outer_iterations if outer_iterations is None else outer_iterations
        outer_iterations = max(1, outer_iterations - skip_outer)
        # TEB resizes until nothing changes when it predicts moving obstacles, whose edges depend on the poses'
        # times; here only when one is near the band (none or far away: the static planner, bit for bit).
        fast_mode = not (self.cfg.obstacles.include_dynamic_obstacles
                         and self.dynamic_obstacles_near(band, dynamic_obstacles))
        for outer in range(outer_iterations):
            if trajectory.teb_autosize:
                band.auto_resize(trajectory.dt_ref, trajectory.dt_hysteresis, trajectory.min_samples,
                                 trajectory.max_samples, fast_mode)
            edges = self.build_edges(band, obstacles, via_points, optim.weight_obstacle * multiplier,
                                     dynamic_obstacles, optim.weight_dynamic_obstacle * multiplier)
            self.levenberg_marquardt(band, edges, optim.no_inner_iterations)
            if compute_cost and outer == outer_iterations - 1:
                cost = self.selection_cost(band, edges)
            multiplier *= optim.weight_adapt_factor
        return cost

    def build_edges(self, band, obstacles, via_points, obstacle_weight, dynamic_obstacles=None,
                    dynamic_weight: float = 0.0) -> EdgeSet:
        cfg = self.cfg
        empty = np.zeros(0, dtype=np.int64)
        if obstacles is not None and len(obstacles) and cfg.optim.weight_obstacle > 0:
            pi, oi, gap = associate_obstacles(self.model, band.poses, obstacles, cfg.obstacles.min_obstacle_dist,
                                              cfg.obstacles.obstacle_association_force_inclusion_factor,
                                              cfg.obstacles.obstacle_association_cutoff_factor)
            obst_point = obstacles[oi]
        else:
            pi, obst_point, gap = empty, np.zeros((0, 2)), np.zeros(0)
        vp, vpts = empty, np.zeros((0, 2))
        n = len(band.poses)
        if via_points is not None and len(via_points) and cfg.optim.weight_viapoint > 0 and n > 2:
            vpts = np.asarray(via_points, dtype=float).reshape(-1, 2)
            if cfg.trajectory.via_points_ordered:
                d2 = ((band.poses[None, 1:-1, :2] - vpts[:, None, :]) ** 2).sum(axis=2)
                idx, start = [], 0
                for row in d2:
                    k = start + int(np.argmin(row[start:])) if start < len(row) else len(row) - 1
                    idx.append(k)
                    start = k + 1
                vp = np.array(idx, dtype=np.int64) + 1
            else:
                # AddEdgesViaPoints: a via-point nearest to the fixed start pose is one the robot has
                # reached or passed and is skipped (pulling pose 1 back to it would turn the band
                # round); one nearest to the goal goes to the pose before it.
                nearest = np.argmin(((band.poses[None, :, :2] - vpts[:, None, :]) ** 2).sum(axis=2), axis=1)
                vp, vpts = np.minimum(nearest[nearest > 0], n - 2), vpts[nearest > 0]
        edges = EdgeSet(pi, obst_point, gap, vp, vpts, obstacle_weight, n=n - 1, dynamic_weight=dynamic_weight)
        if dynamic_obstacles is not None and len(dynamic_obstacles) and cfg.optim.weight_dynamic_obstacle > 0:
            edges.dyn_pose, edges.dyn_obstacle = dynamic_obstacle_edges(self.model, band.poses, band.time_stamps,
                                                                        dynamic_obstacles, self.dynamic_reach,
                                                                        motion_prediction(cfg))
        return edges

    @property
    def dynamic_reach(self) -> float:
        """Distance from the model's outline within which a predicted obstacle gets an edge (§4.8)."""
        obstacles = self.cfg.obstacles
        return max(obstacles.min_obstacle_dist * obstacles.obstacle_association_cutoff_factor,
                   obstacles.min_obstacle_dist + self.cfg.optim.penalty_epsilon,
                   obstacles.dynamic_obstacle_inflation_dist)

    def dynamic_obstacles_near(self, band: TimedElasticBand, dynamic_obstacles: np.ndarray | None) -> bool:
        """Whether a moving obstacle comes within reach of the band as it stands (it would get an edge)."""
        if dynamic_obstacles is None or len(dynamic_obstacles) == 0 or len(band.poses) < 3:
            return False
        return len(dynamic_obstacle_edges(self.model, band.poses, band.time_stamps, dynamic_obstacles,
                                          self.dynamic_reach, motion_prediction(self.cfg))[0]) > 0

    @property
    def with_inflation(self) -> bool:
        obstacles = self.cfg.obstacles
        return obstacles.inflation_dist > obstacles.min_obstacle_dist and self.cfg.optim.weight_inflation > 0

    def parameters(self, edges: EdgeSet) -> np.ndarray:
        return edge_kernels.edge_parameters(self.cfg, edges.obstacle_weight, self.start_velocity, self.free_goal_vel,
                                            self.with_inflation, int(self.prefer_rotdir), edges.dynamic_weight)

    def residual_count(self, edges: EdgeSet, params: np.ndarray) -> int:
        return edge_kernels.residual_count(edges.n, len(edges.obst_pose), len(edges.via_pose), len(edges.dyn_pose),
                                           params)

    def levenberg_marquardt(self, band: TimedElasticBand, edges: EdgeSet, iterations: int) -> None:
        if edges.n < 1:
            return
        params = self.parameters(edges)
        poses = np.array(band.poses, dtype=float)
        dts = np.array(band.time_diffs, dtype=float)
        solver_kernels.levenberg_marquardt(poses, dts, params, edges.arrays, self.model.kernel_model,
                                    self.residual_count(edges, params), iterations)
        band.poses, band.time_diffs = poses, dts

    def selection_cost(self, band: TimedElasticBand, edges: EdgeSet) -> float:
        """computeCurrentCost: chi2 of all edges, obstacle (static and dynamic) and via-point edges
        rescaled for the homotopy selection; the total time replaces the time-optimal edges if asked."""
        hcp = self.cfg.hcp
        params = self.parameters(edges)
        chi2 = edge_kernels.family_chi2(band.poses, band.time_diffs, params, edges.arrays, self.model.kernel_model,
                                   self.residual_count(edges, params))
        chi2[edge_kernels.F_OBSTACLE] *= hcp.selection_obst_cost_scale
        chi2[edge_kernels.F_DYNAMIC] *= hcp.selection_obst_cost_scale
        chi2[edge_kernels.F_VIA] *= hcp.selection_viapoint_cost_scale
        if hcp.selection_alternative_time_cost:
            chi2[edge_kernels.F_TIME] = band.sum_of_time_diffs
        return float(chi2.sum())


def warm_up() -> None:
    """Compile (or load from numba's cache) the kernels of a control cycle on a tiny band, so the
    first goal does not wait for the compiler."""
    from simplebot_navigation.perception.prediction import full_rows
    from simplebot_navigation.teb.config import TebConfig
    from simplebot_navigation.teb.evasion_kernels import rollout_contacts, rollouts
    from simplebot_navigation.teb.footprint import FootprintModel

    band = TimedElasticBand(np.column_stack([np.linspace(0.0, 1.5, 4), np.zeros(4), np.zeros(4)]), np.full(3, 0.3))
    moving = np.array([[1.0, -0.5, 0.0, 1.0, 0.2]])
    TebOptimizer(TebConfig(), FootprintModel.point()).optimize(band, np.array([[0.7, 0.4]]), np.array([[1.0, 0.1]]),
                                                              (0.0, 0.0), False, dynamic_obstacles=moving)
    poses = rollouts(0.0, 0.0, 0.0, 0.0, 0.0, np.ones((1, 2)), 1.0, 1.0, 0.1, 3)
    rollout_contacts(poses, np.arange(4) * 0.1, full_rows(moving), FootprintModel.point().kernel_model, 0.0, 0.1,
                     0.05, 0.5, 4.0, 0.3, 0.0)
