"""Homotopy class planning, simple version: several bands through distinct gaps, the cheapest wins.

TEB's full HCP samples a roadmap and compares H-signatures against every point obstacle, which
is what makes it slow with costmap cells (docs/reference.md §4.7). Here a band's class is the
angles it sweeps around clusters of lethal cells and around the moving obstacles
(teb/homotopy_classes.py). New candidates are seeded by offset initial paths passing left and
right of the clusters closest to the start-goal line and of the points where the robot would meet
the moving obstacles, at most max_number_classes bands in total. To bound the work
of a control cycle, at most one new class is seeded per cycle, it gets one outer iteration in
that cycle and competes from the next one, and a seed that merges into another class or is
dropped as a detour is not tried again near the same detour point for REJECTED_SEED_CYCLES
cycles. The alternatives to the band being followed are warm-started every cycle and run only
the later half of the outer loop (at the same final obstacle weight, so their costs stay
comparable); the followed band gets the full loop, first. A wall-clock deadline is the safety
net on top of that bound: once it has passed, the alternatives sit the cycle out.

With enable_homotopy_class_planning false the planner keeps exactly one band (TebOptimalPlanner).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.teb.band import TimedElasticBand
from simplebot_navigation.teb.homotopy_classes import (EMPTY_SIGNATURE, Signature, cluster_keypoint,
                                                       homotopy_signature, moving_detours, moving_signature,
                                                       obstacle_clusters, path_times, same_class)
from simplebot_navigation.teb.obstacles import motion_prediction
from simplebot_navigation.teb.optimizer import RotType, TebOptimizer


@dataclass
class Candidate:
    band: TimedElasticBand
    from_initial_plan: bool = False
    cost: float = math.inf
    signature: Signature = EMPTY_SIGNATURE
    fresh_seed: bool = False
    seed_point: np.ndarray | None = None      # the detour point a seed was built through


#: Control cycles during which a seed that did not survive its first optimisation is not re-seeded
#: (TEB re-explores every cycle; in Python each wasted candidate costs a full optimisation).
REJECTED_SEED_CYCLES = 20
#: ... through a detour point closer than this to the rejected seed's one [m]
REJECTED_SEED_RADIUS = 0.5


class HomotopyClassPlanner:
    def __init__(self, cfg, model):
        self.cfg = cfg
        self.model = model
        self.optimizer = TebOptimizer(cfg, model)
        self.candidates: list[Candidate] = []
        self.best: Candidate | None = None
        self.keypoints = np.zeros((0, 2))
        #: moving obstacles of the cycle (prediction rows, perception/prediction.py)
        self.moving = np.zeros((0, 5))
        #: bands optimised in the last cycle (candidates before duplicates and detours are dropped)
        self.bands_optimized = 0
        #: bands left out of the last cycle because its deadline had passed
        self.postponed = 0
        # Detour points of seeds that merged into another class or were dropped as detours,
        # with the cycles left during which no seed is built through their neighbourhood.
        self.rejected: list[tuple[np.ndarray, int]] = []

    @property
    def enabled(self) -> bool:
        return self.cfg.hcp.enable_homotopy_class_planning

    def clear(self) -> None:
        self.candidates = []
        self.best = None
        self.rejected = []

    def best_band(self) -> TimedElasticBand | None:
        return self.best.band if self.best else None

    def set_preferred_turning_dir(self, rotdir: RotType) -> None:
        """Every candidate band is optimised with it (they share the optimiser), so the selection
        compares them under the same prefer_rotdir edges."""
        self.optimizer.prefer_rotdir = rotdir

    # -- one planning cycle -----------------------------------------------------------------
    def plan(self, initial_plan: np.ndarray, obstacles: np.ndarray, via_points, start_velocity,
             free_goal_vel: bool, bounds=None, class_obstacles: np.ndarray | None = None,
             deadline: float | None = None, dynamic_obstacles: np.ndarray | None = None) -> bool:
        """initial_plan (K,3): robot pose first, local goal last. bounds: (xmin, ymin, xmax, ymax)
        of the local costmap, where seeds may place their detour points. class_obstacles: every
        lethal cell of the local costmap (default: ``obstacles``). The optimiser's container skips
        cells far behind the robot, but a wall does not end where that filter cuts it: clusters,
        signatures and seed clearance use the whole map, or a seed would be routed around the cut
        end of a wall, straight through the part behind the robot.

        deadline (time.perf_counter()): once passed, the bands other than the followed one are not
        optimised this cycle (counted in ``postponed``). The followed band goes first and is always
        optimised. The work per cycle is bounded by the configuration alone (max_number_classes
        bands, one new seed, fixed iteration counts), so on a machine fast enough the deadline is
        never reached and lock-step runs stay reproducible; it is only a safety net.

        dynamic_obstacles: prediction rows (perception/prediction.py), for the optimiser, the classes
        and the seeds (velocities zeroed when they are not to be predicted)."""
        cfg = self.cfg
        start, goal = initial_plan[0], initial_plan[-1]
        self.moving = np.zeros((0, 5)) if dynamic_obstacles is None else dynamic_obstacles
        self._update_candidates(start, goal)
        if self.enabled:
            gap = max(2.0 * self.model.inscribed_radius, 0.1)
            if class_obstacles is None:
                class_obstacles = obstacles
            clusters = obstacle_clusters(class_obstacles, gap)
            self.keypoints = (np.array([cluster_keypoint(c) for c in clusters]) if clusters
                              else np.zeros((0, 2)))
            for cand in self.candidates:
                cand.signature = self._band_signature(cand.band)
            self._drop_duplicates()
            self._ensure_initial_plan_candidate(initial_plan)
            self._explore(start, goal, clusters, class_obstacles, bounds)
        elif not self.candidates:
            self.candidates = [self._new_candidate(initial_plan, True)]
        if not cfg.optim.optimization_activate:
            self.best = self.candidates[0] if self.candidates else None
            return self.best is not None
        self._optimize_candidates(obstacles, via_points, start_velocity, free_goal_vel, deadline)
        if self.enabled:
            seeds = {id(c): c.seed_point for c in self.candidates if c.fresh_seed}
            for cand in self.candidates:
                cand.signature = self._band_signature(cand.band)
                cand.fresh_seed = False
            self._drop_duplicates()
            self._delete_detours()
            kept = {id(c) for c in self.candidates}
            self.rejected = [(sig, ttl - 1) for sig, ttl in self.rejected if ttl > 1]
            self.rejected += [(via, REJECTED_SEED_CYCLES) for key, via in seeds.items() if key not in kept]
            self._select_best()
        else:
            self.best = self.candidates[0]
        return self.best is not None

    def _optimize_candidates(self, obstacles, via_points, start_velocity, free_goal_vel, deadline) -> None:
        """The followed band first, with the full outer loop, then the others until the deadline."""
        cfg = self.cfg
        self.bands_optimized = self.postponed = 0
        followed = self._followed()
        late_seeds = []
        for cand in sorted(self.candidates, key=lambda c: c is not followed):
            if cand is not followed and deadline is not None and time.perf_counter() > deadline:
                # Out of time (a slow or overloaded machine): an alternative sits this cycle out and
                # cannot be selected, a new seed is dropped without blame and explored again later.
                self.postponed += 1
                cand.cost = math.inf
                if cand.fresh_seed:
                    late_seeds.append(cand)
                continue
            self.bands_optimized += 1
            if cand.fresh_seed:
                # A new class gets one outer iteration now and competes from the next cycle on.
                self.optimizer.optimize(cand.band, obstacles, via_points, start_velocity, free_goal_vel,
                                        compute_cost=False, outer_iterations=1, dynamic_obstacles=self.moving)
                cand.cost = math.inf
            else:
                # Alternatives to the band being followed run the later half of the outer loop.
                skip = cfg.optim.no_outer_iterations // 2 if cand is not self.best and self.best is not None else 0
                cand.cost = self.optimizer.optimize(cand.band, obstacles, via_points, start_velocity,
                                                    free_goal_vel, compute_cost=self.enabled, skip_outer=skip,
                                                    dynamic_obstacles=self.moving)
        self.candidates = [c for c in self.candidates if c not in late_seeds]

    def _followed(self) -> Candidate | None:
        """The band the robot follows: the selected one, else the global plan's (a new start)."""
        if self.best is not None:
            return self.best
        return next((c for c in self.candidates if c.from_initial_plan),
                    self.candidates[0] if self.candidates else None)

    def _update_candidates(self, start, goal) -> None:
        """Warm start every band, or drop them all when the goal moved too far (force_reinit_*)."""
        cfg = self.cfg
        keep = []
        for cand in self.candidates:
            back = cand.band.poses[-1]
            if (math.hypot(goal[0] - back[0], goal[1] - back[1]) < cfg.trajectory.force_reinit_new_goal_dist
                    and abs(float(normalize_theta(goal[2] - back[2]))) < cfg.trajectory.force_reinit_new_goal_angular):
                cand.band.update_and_prune(start, goal, cfg.trajectory.min_samples)
                keep.append(cand)
        if len(keep) != len(self.candidates):
            keep = []
            self.best = None
        self.candidates = keep

    def _new_candidate(self, path: np.ndarray, from_initial_plan: bool) -> Candidate:
        band = TimedElasticBand()
        robot, trajectory = self.cfg.robot, self.cfg.trajectory
        band.init_from_path(path, robot.max_vel_x, robot.max_vel_theta, trajectory.global_plan_overwrite_orientation,
                            trajectory.min_samples, trajectory.allow_init_with_backwards_motion)
        return Candidate(band, from_initial_plan, signature=self._band_signature(band))

    def _signature(self, path_xy: np.ndarray, times: np.ndarray) -> Signature:
        return Signature(homotopy_signature(path_xy, self.keypoints),
                         moving_signature(path_xy, times, self.moving, motion_prediction(self.cfg)))

    def _band_signature(self, band: TimedElasticBand) -> Signature:
        return self._signature(band.poses[:, :2], band.time_stamps)

    def _has_class(self, signature) -> Candidate | None:
        for cand in self.candidates:
            if same_class(cand.signature, signature):
                return cand
        return None

    def _drop_duplicates(self) -> None:
        """Keep one band per class: the current best, else the cheaper one."""
        kept: list[Candidate] = []
        for cand in sorted(self.candidates, key=lambda c: (c is not self.best, c.cost)):
            twin = next((k for k in kept if same_class(k.signature, cand.signature)), None)
            if twin is None:
                kept.append(cand)
            elif cand.from_initial_plan:
                twin.from_initial_plan = True
        self.candidates = kept

    def _ensure_initial_plan_candidate(self, initial_plan) -> None:
        sig = self._signature(initial_plan[:, :2], path_times(initial_plan[:, :2], self.cfg.robot.max_vel_x))
        for cand in self.candidates:
            cand.from_initial_plan = False
        twin = self._has_class(sig)
        if twin is not None:
            twin.from_initial_plan = True
        elif len(self.candidates) < self.cfg.hcp.max_number_classes:
            self.candidates.append(self._new_candidate(initial_plan, True))
        else:
            # The global plan's class always gets a band; it replaces the most expensive one.
            worst = max((c for c in self.candidates if c is not self.best), key=lambda c: c.cost,
                        default=self.candidates[-1])
            self.candidates.remove(worst)
            self.candidates.append(self._new_candidate(initial_plan, True))

    def _explore(self, start, goal, clusters, obstacles, bounds) -> None:
        """Seed bands left and right of the clusters nearest to the start-goal line, and of the
        points where the robot would meet a moving obstacle, nearest to the line first."""
        cfg = self.cfg
        axis = goal[:2] - start[:2]
        length = float(np.hypot(*axis))
        if length < 2 * cfg.obstacles.min_obstacle_dist or not (clusters or len(self.moving)):
            return
        axis /= length
        normal = np.array([-axis[1], axis[0]])
        half_width = 0.5 * cfg.hcp.roadmap_graph_area_width
        for t_w, offsets in self._detours(start, axis, normal, length, clusters):
            for offset in offsets:
                if len(self.candidates) >= cfg.hcp.max_number_classes:
                    return
                via = start[:2] + t_w * axis + offset * normal
                if bounds is not None and not (bounds[0] <= via[0] <= bounds[2] and bounds[1] <= via[1] <= bounds[3]):
                    continue
                if abs(offset) > half_width or not _segments_clear(
                        np.array([start[:2], via, goal[:2]]), obstacles, self.model.inscribed_radius):
                    continue
                path = _polyline(np.array([start[:2], via, goal[:2]]), cfg.robot.max_vel_x * cfg.trajectory.dt_ref)
                heading = np.diff(path, axis=0)
                seed = np.column_stack([path, np.append(np.arctan2(heading[:, 1], heading[:, 0]), 0.0)])
                seed[0], seed[-1] = start, goal
                sig = self._signature(seed[:, :2], path_times(seed[:, :2], cfg.robot.max_vel_x))
                if self._has_class(sig) is None and not any(
                        np.hypot(*(via - r)) < REJECTED_SEED_RADIUS for r, _ in self.rejected):
                    cand = self._new_candidate(seed, False)
                    cand.signature = sig
                    cand.fresh_seed = True
                    cand.seed_point = via
                    self.candidates.append(cand)
                    return  # one new class per cycle bounds the cycle time

    def _detours(self, start, axis, normal, length: float, clusters) -> list[tuple[float, tuple[float, float]]]:
        """(distance along the start-goal line, (left, right) lateral offsets) of the detour points
        around each cluster and each moving obstacle's meeting point within roadmap_graph_area_width,
        nearest to the line first."""
        cfg = self.cfg
        half_width = 0.5 * cfg.hcp.roadmap_graph_area_width
        clearance = self.model.inscribed_radius + cfg.obstacles.min_obstacle_dist
        ranked = []
        for pts in clusters:
            rel = pts - start[:2]
            t, lat = rel @ axis, rel @ normal
            inside = (t > 0) & (t < length) & (np.abs(lat) < half_width)
            if inside.any():
                t_w = float(np.clip(np.mean(t[inside]), 0.25 * length, 0.75 * length))
                ranked.append((float(np.min(np.abs(lat[inside]))), t_w,
                               (float(lat[inside].max()) + clearance, float(lat[inside].min()) - clearance)))
        for t, lat, radius in moving_detours(start, axis, length, self.moving, cfg.robot.max_vel_x):
            if 0 < t < length and abs(lat) - radius < half_width:
                t_w = float(np.clip(t, 0.25 * length, 0.75 * length))
                ranked.append((max(abs(lat) - radius, 0.0), t_w, (lat + radius + clearance, lat - radius - clearance)))
        ranked.sort(key=lambda r: r[0])
        return [(t_w, offsets) for _, t_w, offsets in ranked]

    def _delete_detours(self) -> None:
        """Drop bands with a pose heading against the start-goal direction (dot < -0.1, with
        delete_detours_backwards) or taking longer than max_ratio_detours_duration_best_duration
        times the fastest band. The band being followed is locked, as TEB locks the best class:
        a detour the robot has committed to is not deleted under it."""
        hcp = self.cfg.hcp
        if len(self.candidates) < 2:
            return
        fastest = min(c.band.sum_of_time_diffs for c in self.candidates)
        kept = []
        for cand in self.candidates:
            poses = cand.band.poses
            d = poses[-1, :2] - poses[0, :2]
            norm = float(np.hypot(*d))
            backwards = (hcp.delete_detours_backwards and norm > 1e-9 and
                         bool(np.any((np.cos(poses[:, 2]) * d[0] + np.sin(poses[:, 2]) * d[1]) / norm < -0.1)))
            too_long = cand.band.sum_of_time_diffs > hcp.max_ratio_detours_duration_best_duration * fastest
            if (backwards or too_long) and cand is not self.best:
                continue
            kept.append(cand)
        self.candidates = kept or self.candidates

    def _select_best(self) -> None:
        hcp = self.cfg.hcp
        best, best_cost = None, math.inf
        for cand in self.candidates:
            cost = cand.cost
            if cand is self.best:
                cost *= hcp.selection_cost_hysteresis
            elif cand.from_initial_plan:
                cost *= hcp.selection_prefer_initial_plan
            if cost < best_cost or best is None:
                best, best_cost = cand, cost
        self.best = best

    def remove_infeasible_best(self, is_feasible) -> bool:
        """Try the best band; while it is infeasible drop it and re-select, but give up at once if
        the infeasible band was already the previous choice (switching then would oscillate)."""
        previous = self.best
        while self.candidates:
            if self.best is None:
                return False
            if is_feasible(self.best.band):
                return True
            failed = self.best
            self.candidates.remove(failed)
            if not self.enabled or failed is previous:
                self.best = None
                return False
            self._select_best()
        self.best = None
        return False


def _segments_clear(points: np.ndarray, obstacles: np.ndarray, radius: float) -> bool:
    """True when no obstacle lies within ``radius`` of the polyline through ``points``: a seed
    must not start out crossing a wall (TEB's roadmap edges are checked the same way)."""
    if len(obstacles) == 0:
        return True
    a, b = points[:-1], points[1:]
    ab = b - a
    rel = obstacles[:, None, :] - a[None, :, :]
    t = np.clip((rel * ab).sum(axis=2) / np.maximum((ab * ab).sum(axis=1), 1e-12), 0.0, 1.0)
    closest = rel - t[..., None] * ab
    return bool(np.min(np.einsum("msj,msj->ms", closest, closest)) >= radius * radius)


def _polyline(points: np.ndarray, spacing: float) -> np.ndarray:
    """Resample a polyline at about ``spacing`` metres, keeping its vertices."""
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:]):
        n = max(1, int(math.ceil(np.hypot(*(b - a)) / spacing)))
        f = np.arange(1, n + 1)[:, None] / n
        out.append(a + f * (b - a))
    return np.vstack(out)
