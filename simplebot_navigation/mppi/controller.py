"""MppiController: one control cycle of MPPILocalPlannerROS free of ROS (docs/reference.md §4.10). The ROS shell feeds
it the global plan (in the local costmap's frame), the moving obstacles, and per cycle the robot pose, the odometry
velocity and the local Costmap2D; it reads back the command and the trajectory it starts.

A cycle: the plan ahead of the robot, resampled; among moving obstacles, every guide_period, the space-time guide
(guide.py), which then stands in for the plan ahead; the sequence optimised (optimizer.py); the command chosen by
the passive safety (safety.py). Within half the xy tolerance of the goal the robot brakes and turns to the goal's yaw
in place, until it leaves the tolerance again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import distance_transform_edt

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.mppi import kernels
from simplebot_navigation.mppi.body import body_circles, outline_points
from simplebot_navigation.mppi.config import MppiConfig
from simplebot_navigation.mppi.guide import SpaceTimeGuide
from simplebot_navigation.mppi.optimizer import MppiOptimizer, Scene
from simplebot_navigation.mppi.safety import Decision, decide, judge, manoeuvres, unseen
from simplebot_navigation.parameters import fields_of, set_value, value_of
from simplebot_navigation.perception.prediction import MotionPrediction, checked_dynamic_obstacles, prediction_rows

#: spacing (m) of the plan points the critics measure against
PATH_SPACING_M = 0.1
#: the turn to the goal's yaw starts within this share of xy_goal_tolerance
GOAL_LATCH_SHARE = 0.5
#: the closest plan point is looked for this far (m) along the plan beyond the last one, at least
PLAN_SEARCH_M = 2.0
#: a track lost within this clearance (m) of the body is kept, moving on at its velocity, for KEEP_LOST_S (s, the
#: tracker's max_coast_time): an obstacle that touches the robot lies inside the lidars' minimum range and drops
#: out of the tracker
KEEP_LOST_M, KEEP_LOST_S = 0.3, 2.5


@dataclass
class CycleResult:
    ok: bool
    v: float = 0.0
    omega: float = 0.0
    message: str = ""
    kind: str = ""          # the passive safety's choice (safety.Decision.kind), or "rotate" at the goal


class MppiController:
    """One instance per move_base; every method is called on the control thread."""

    def __init__(self, cfg: MppiConfig, costmap_footprint, controller_period: float, seed: int = 0):
        if not controller_period > 0:
            raise ValueError(f"controller_period must be > 0, got {controller_period}")
        self.cfg = cfg
        self.controller_period = float(controller_period)
        self.optimizer = MppiOptimizer(cfg, seed)
        self.guide = SpaceTimeGuide(cfg)
        #: the space-time guide as (G, 3) rows t, x, y from when it was planned, and the time since (s)
        self._guide, self._guide_age = np.zeros((0, 3)), math.inf
        self._lethal_distance = LethalDistance()
        self.set_costmap_footprint(costmap_footprint)
        self.plan = np.zeros((0, 3))
        self._index = 0
        self._latched = False
        self._rows = np.zeros((0, 5))
        self._covariance = np.zeros((0, 4, 4))
        self._started = False
        #: tracks lost near the body: rows (K, 5), covariances (K, 4, 4), seconds since they were last seen
        self._lost = (np.zeros((0, 5)), np.zeros((0, 4, 4)), np.zeros(0))
        self._near = (np.zeros((0, 5)), np.zeros((0, 4, 4)))
        #: the trajectory the last command starts (T, 3), for the local_plan topic; the last decision's kind
        self.trajectory = np.zeros((0, 3))
        self.last_kind = ""
        self._notices: list[tuple[str, str]] = []
        self._dropped_reported = False
        #: the cycle's prediction from its settings (MotionPrediction: constant velocity). A benchmark hands in one
        #: that knows the obstacles' true future (testing/crowd_drive.py), to measure what prediction costs.
        self.prediction_for = lambda settings: settings

    # -- run-time changes ---------------------------------------------------------------------------
    def reconfigure(self, cfg: MppiConfig) -> None:
        """New parameters (already checked) from the next cycle; the horizon's length may change, so the sequence
        starts again from the current velocity."""
        for name, spec in fields_of(MppiConfig).items():
            if spec.dynamic:
                set_value(self.cfg, name, value_of(cfg, name))
        self._started = False
        self._guide_age = math.inf

    def set_controller_period(self, controller_period: float) -> None:
        if not controller_period > 0:
            raise ValueError(f"controller_period must be > 0, got {controller_period}")
        self.controller_period = float(controller_period)

    def set_costmap_footprint(self, footprint) -> None:
        self.footprint = np.asarray(footprint, dtype=float).reshape(-1, 2)
        self.circles = body_circles(self.footprint)
        self._outline_for: tuple[float, np.ndarray] | None = None

    def _outline(self, resolution: float) -> np.ndarray:
        if self._outline_for is None or self._outline_for[0] != resolution:
            self._outline_for = (resolution, outline_points(self.footprint, resolution))
        return self._outline_for[1]

    # -- inputs ---------------------------------------------------------------------------------------
    def set_plan(self, plan) -> None:
        """A new global plan ((N, 3) x, y, yaw in the local costmap's frame)."""
        plan = np.asarray(plan, dtype=float)
        if plan.ndim != 2 or plan.shape[1] != 3 or len(plan) == 0:
            raise ValueError(f"global plan must be a non-empty (N, 3) array of x, y, yaw; got shape {plan.shape}")
        self.plan = plan.copy()
        self._index = 0
        self._latched = False
        self._guide_age = math.inf

    def move_plan(self, plan) -> None:
        """The same plan seen anew in the local frame (map -> odom moved)."""
        self.plan = np.asarray(plan, dtype=float).copy()

    def set_dynamic_obstacles(self, rows, covariance=None) -> None:
        """Moving obstacles (K, 5) x, y, vx, vy, radius at the coming cycle's time, and their (K, 4, 4)
        covariances (or None); rows that are not valid are dropped, reported once."""
        rows, cov, dropped = checked_dynamic_obstacles(rows, covariance)
        if dropped and not self._dropped_reported:
            self._dropped_reported = True
            self._notices.append(("warn", f"MPPI: dropped {dropped}. Reported once."))
        self._rows, self._covariance = rows, (cov if cov is not None else np.zeros((len(rows), 4, 4)))

    def reset(self) -> None:
        """The goal ended: forget the plan, the sequence and the lost tracks."""
        self.plan = np.zeros((0, 3))
        self._lost = (np.zeros((0, 5)), np.zeros((0, 4, 4)), np.zeros(0))
        self._near = (np.zeros((0, 5)), np.zeros((0, 4, 4)))
        self._started = False
        self._latched = False
        self._guide_age = math.inf
        self.trajectory = np.zeros((0, 3))

    def pop_notices(self) -> list[tuple[str, str]]:
        notices, self._notices = self._notices, []
        return notices

    # -- the cycle ------------------------------------------------------------------------------------
    def is_goal_reached(self, pose, velocity) -> bool:
        if len(self.plan) == 0:
            return False
        tol = self.cfg.goal_tolerance
        goal = self.plan[-1]
        return (math.hypot(goal[0] - pose[0], goal[1] - pose[1]) < tol.xy_goal_tolerance
                and abs(float(normalize_theta(goal[2] - pose[2]))) < tol.yaw_goal_tolerance
                and abs(velocity[0]) <= tol.trans_stopped_velocity and abs(velocity[1]) <= tol.rot_stopped_velocity)

    def compute_velocity_commands(self, pose, velocity, costmap) -> CycleResult:
        if len(self.plan) == 0:
            return CycleResult(False, message="no global plan set")
        state = np.array([pose[0], pose[1], pose[2], velocity[0], velocity[1]], dtype=float)
        if not np.isfinite(state).all():
            return CycleResult(False, message=f"robot state is not finite: pose {tuple(pose)}, velocity {velocity}")
        cost = kernels.cell_cost(costmap.costmap, costmap.origin_x, costmap.origin_y, costmap.resolution,
                                 state[0], state[1])
        if cost in (kernels.INSCRIBED, kernels.LETHAL):
            self._started = False
            return CycleResult(False, message="the robot's centre is in an inscribed or lethal cell of the local "
                                              "costmap")
        if not self._started:
            self.optimizer.reset(state[3:5])
            self._started = True
        scene = self._scene(state, costmap)
        hold = max(1, round(self.controller_period / self.cfg.sampling.model_dt))
        goal = self.plan[-1]
        distance = math.hypot(goal[0] - state[0], goal[1] - state[1])
        tol = self.cfg.goal_tolerance.xy_goal_tolerance
        self._latched = distance < tol and (self._latched or distance < GOAL_LATCH_SHARE * tol)
        if self._latched:
            decision = self._rotate(scene, goal[2], hold)
        else:
            samples = self.optimizer.optimize(scene)
            if self.cfg.moving_obstacles.passive_safety:
                decision = decide(self.optimizer, scene, samples, hold)
            else:
                controls, poses = self.optimizer.rollout(state, self.optimizer.sequence[None])
                decision = Decision("plan (unverified)", controls[0], poses[0], controls[0])
            self.optimizer.sequence = decision.sequence
            self.optimizer.shift(hold)
        self.trajectory = decision.poses
        self.last_kind = decision.kind
        v, omega = decision.command
        return CycleResult(True, v, omega, kind=decision.kind)

    def _rotate(self, scene: Scene, goal_yaw: float, hold: int) -> Decision:
        """Brake and turn towards the goal's yaw, as fast as the turn can still be stopped on it; verified like
        every command (braking instead)."""
        limits = self.cfg.limits
        error = float(normalize_theta(goal_yaw - scene.state[2]))
        turn = math.copysign(min(limits.wz_max, 0.8 * math.sqrt(2.0 * limits.az_max * abs(error))), error)
        if abs(error) < 0.5 * self.cfg.goal_tolerance.yaw_goal_tolerance:
            turn = 0.0
        steps = self.optimizer.sequence.shape[0]
        heads = np.array([[(0.0, turn)] * hold, [(0.0, 0.0)] * hold])
        controls, poses = self.optimizer.rollout(scene.state, manoeuvres(heads, steps))
        scored = self.optimizer.evaluate(scene, controls, poses)
        _, passive = judge(scored, unseen(self.optimizer, scene, controls, poses), self.cfg.sampling.model_dt)
        row = 0 if passive[0] else 1
        return Decision("rotate" if row == 0 else "brake", controls[row], poses[row], controls[row])

    def _with_lost_tracks(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """This cycle's obstacles, plus those that were near the body last cycle and are gone now (KEEP_LOST_M)."""
        period = self.controller_period
        rows, cov, age = self._lost
        near_rows, near_cov = self._near
        kept = np.ones(len(near_rows), dtype=bool)
        for i, row in enumerate(near_rows):       # still tracked if a row is where it should be now
            ahead = row[:2] + period * row[2:4]
            kept[i] = not (np.hypot(*(self._rows[:, :2] - ahead).T) < KEEP_LOST_M + row[4]).any()
        moved = np.array(near_rows[kept])
        moved[:, :2] += period * moved[:, 2:4]
        rows = rows.copy()
        rows[:, :2] += period * rows[:, 2:4]
        rows, cov = np.concatenate([rows, moved]), np.concatenate([cov, near_cov[kept]])
        age = np.concatenate([age + period, np.full(kept.sum(), period)])
        young = age <= KEEP_LOST_S
        self._lost = (rows[young], cov[young], age[young])
        clearance = np.hypot(*(self._rows[:, :2] - state[:2]).T) - self._rows[:, 4] - self.circles[:, 2].max() \
            - np.hypot(*self.circles[:, :2].T).max()
        self._near = (self._rows[clearance < KEEP_LOST_M], self._covariance[clearance < KEEP_LOST_M])
        return np.concatenate([self._rows, rows[young]]), np.concatenate([self._covariance, cov[young]])

    def _scene(self, state: np.ndarray, costmap) -> Scene:
        cfg = self.cfg
        path, target, remaining = self._path_ahead(state)
        moving = cfg.moving_obstacles
        rows, covariance = self._with_lost_tracks(state)
        rows = prediction_rows(rows, covariance, moving.dynamic_obstacle_uncertainty_sigmas)
        prediction = self.prediction_for(MotionPrediction(moving.dynamic_obstacle_prediction_horizon or math.inf,
                                                          moving.dynamic_obstacle_max_uncertainty,
                                                          moving.dynamic_obstacle_radius_growth))
        guide = self._guide_ahead(state, costmap, rows, prediction)
        if len(guide):
            path = guide[:, 1:]
            horizon = cfg.sampling.time_steps * cfg.sampling.model_dt
            target = np.array([np.interp(horizon, guide[:, 0], guide[:, 1]),
                               np.interp(horizon, guide[:, 0], guide[:, 2])])
        return Scene(state, path, target, self.plan[-1].copy(), remaining <= cfg.critics.threshold_to_consider,
                     costmap.costmap, self._lethal_distance(costmap),
                     (costmap.origin_x, costmap.origin_y, costmap.resolution),
                     self._outline(costmap.resolution), self.circles, np.ascontiguousarray(rows), prediction,
                     prediction.table(rows, cfg.sampling.model_dt, cfg.sampling.time_steps), guide)

    def _guide_ahead(self, state: np.ndarray, costmap, rows: np.ndarray, prediction: MotionPrediction) -> np.ndarray:
        """The space-time guide from this cycle's time: planned again once guide_period has passed, else the last
        one, a cycle older; (0, 3) when off or there is none."""
        guide = self.cfg.space_time
        if not guide.space_time_guide:
            return np.zeros((0, 3))
        self._guide_age += self.controller_period
        if self._guide_age >= guide.guide_period - 1e-9:
            xy = self.plan[self._index:, :2]
            arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
            xy = xy[arc <= 2 * self.guide.half_width()]
            reach = float(np.max(np.hypot(*self.circles[:, :2].T) + self.circles[:, 2]))
            found = self.guide.plan(state, xy, costmap, rows, prediction, reach)
            self._guide = np.zeros((0, 3)) if found is None else np.column_stack([found.times, found.xy])
            self._guide_age = 0.0
        ahead = self._guide.copy()
        ahead[:, 0] -= self._guide_age
        return ahead

    def _path_ahead(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """The plan from its point closest to the robot (looked for ahead of the last one) up to prune_distance,
        resampled every PATH_SPACING_M; the point of it the rollouts should reach (as far as vx_max goes in the
        horizon); and the plan's length left from the closest point."""
        xy = self.plan[:, :2]
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        start = min(self._index, len(xy) - 1)
        window = np.nonzero(arc <= arc[start] + max(PLAN_SEARCH_M, self.cfg.sampling.prune_distance))[0]
        window = window[window >= start]
        self._index = int(window[np.argmin(np.hypot(*(xy[window] - state[:2]).T))])
        here = arc[self._index]
        end = min(arc[-1], here + self.cfg.sampling.prune_distance)
        along = np.append(np.arange(here, end, PATH_SPACING_M), end)
        path = np.column_stack([np.interp(along, arc, xy[:, 0]), np.interp(along, arc, xy[:, 1])])
        sampling = self.cfg.sampling
        reach = min(end, here + self.cfg.limits.vx_max * sampling.time_steps * sampling.model_dt)
        target = np.array([np.interp(reach, arc, xy[:, 0]), np.interp(reach, arc, xy[:, 1])])
        return path, target, float(arc[-1] - here)


class LethalDistance:
    """Each cell's distance (m) to the nearest lethal cell of the costmap (inf without any), computed again only
    when the lethal cells or the window moved: the costmap updates a few times a second, the controller runs at
    20 Hz, and the transform is a millisecond of a cycle."""

    def __init__(self):
        self._key, self._lethal, self._distance = None, None, None

    def __call__(self, costmap) -> np.ndarray:
        lethal = costmap.costmap == kernels.LETHAL
        key = (costmap.origin_x, costmap.origin_y, costmap.resolution)
        if key != self._key or not np.array_equal(lethal, self._lethal):
            distance = np.full(lethal.shape, np.inf) if not lethal.any() else \
                distance_transform_edt(~lethal) * costmap.resolution
            self._key, self._lethal, self._distance = key, lethal, distance
        return self._distance


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel of a cycle on a tiny scene, so the first goal does not
    wait for the compiler."""
    from simplebot_navigation.costmap.costmap_2d import Costmap2D
    from simplebot_navigation.costmap.footprint import footprint_from_radius

    cfg = MppiConfig.from_params({"batch_size": 64, "time_steps": 8})
    controller = MppiController(cfg, footprint_from_radius(0.2), cfg.sampling.model_dt)
    controller.set_plan(np.column_stack([np.linspace(0.0, 2.0, 5), np.zeros(5), np.zeros(5)]))
    controller.set_dynamic_obstacles(np.array([[1.0, -0.5, 0.0, 1.0, 0.2]]))
    costmap = Costmap2D(20, 20, 0.1, -1.0, -1.0)
    costmap.costmap[0, :] = kernels.LETHAL
    controller.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), costmap)
    controller.set_costmap_footprint([[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]])
    controller.compute_velocity_commands((0.0, 0.0, 0.0), (0.1, 0.0), costmap)
