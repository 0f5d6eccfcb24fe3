"""TebLocalPlanner: the control cycle of TebLocalPlannerROS::computeVelocityCommands (docs/reference.md §4.5),
free of ROS. The ROS shell feeds it the global plan (already in the local costmap frame), the robot
pose and odometry velocity and the local Costmap2D, and publishes what the accessors return.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.costmap.footprint import footprint_radii
from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.parameters import fields_of, set_value, value_of
from simplebot_navigation.teb.command import saturate, velocity_from_band
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.evasion import MIN_GAIN_S, band_contact_time, choose_evasion
from simplebot_navigation.teb.failure_detector import FailureDetector, buffer_length
from simplebot_navigation.teb.feasibility import collision_model, is_trajectory_feasible
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.homotopy import HomotopyClassPlanner
from simplebot_navigation.perception.prediction import checked_dynamic_obstacles
from simplebot_navigation.teb.obstacles import (behind_robot_filter, costmap_point_obstacles, motion_prediction,
                                                planned_motion)
from simplebot_navigation.teb.optimizer import RotType

GOAL_ORIENTATION_AVERAGE = 3
#: Share of controller_period after which a cycle optimises no more alternative bands (the
#: followed band is always optimised; the rest of the period is for the costmap and the shell).
CYCLE_BUDGET_FRACTION = 0.5


@dataclass
class VelocityCommandResult:
    v: float
    omega: float
    ok: bool
    message: str
    goal_reached: bool = False


class TebLocalPlanner:
    """One instance per move_base. Per control cycle: compute_velocity_commands(pose, (v, omega),
    local Costmap2D), after set_dynamic_obstacles with the moving obstacles of that cycle. Between
    cycles the ROS shell reads band_poses / band_time_stamps (local_plan, teb_poses), transformed_plan
    (global_plan), obstacles, dynamic_obstacles and footprint_outlines() (teb_markers)."""

    def __init__(self, config: TebConfig, costmap_footprint, controller_period: float):
        """costmap_footprint: the (padded) footprint polygon the local costmap uses, (K,2) in the
        robot frame -- the feasibility check uses it, the optimiser uses the footprint model."""
        if not controller_period > 0:
            raise ValueError(f"controller_period must be > 0, got {controller_period}")
        self.cfg = config
        self.model = FootprintModel.from_params(config.footprint_model)
        self.warnings = list(config.warnings) + self.model.warnings
        self.costmap_footprint = np.asarray(costmap_footprint, dtype=float).reshape(-1, 2)
        self.costmap_inscribed_radius = footprint_radii(self.costmap_footprint)[0]
        self.collision_model = collision_model(self.costmap_footprint, self.costmap_inscribed_radius)
        if self.model.inscribed_radius + config.obstacles.min_obstacle_dist < self.costmap_inscribed_radius:
            self.warnings.append(
                f"footprint model inscribed radius ({self.model.inscribed_radius:.3f}) + min_obstacle_dist "
                f"({config.obstacles.min_obstacle_dist:.3f}) is smaller than the costmap footprint's inscribed radius "
                f"({self.costmap_inscribed_radius:.3f}): the optimiser may plan into the inflated zone")
        self.controller_period = float(controller_period)
        self.planner = HomotopyClassPlanner(config, self.model)
        self.global_plan = np.zeros((0, 3))
        self.transformed_plan = np.zeros((0, 3))
        self.via_points = np.zeros((0, 2))
        self.obstacles = np.zeros((0, 2))
        #: moving obstacles (K, 5: x, y, vx, vy, radius): the last ones set, and those the last cycle used
        self._next_dynamic_obstacles = np.zeros((0, 5))
        self._next_dynamic_covariance = None
        self.dynamic_obstacles = np.zeros((0, 5))
        self._dropped_dynamic_reported = False
        self.goal_reached = False
        #: infeasible cycles in a row, and control periods' worth of seconds since the last one
        #: (the shell hands in no clock; move_base calls once per controller period)
        self._infeasible_in_a_row = 0
        self._since_infeasible = math.inf
        #: oscillation recovery: the detector fed with the command of the previous cycle, the
        #: seconds (counted like _since_infeasible) since it last reported an oscillation, and the
        #: turning direction the optimiser prefers meanwhile
        self.failure_detector = FailureDetector(buffer_length(config.recovery.oscillation_filter_duration,
                                                              controller_period))
        self._last_command = (0.0, 0.0)
        self._since_oscillation = math.inf
        self.preferred_rotdir = RotType.none
        #: (level, message) pairs, level "warn" or "info"
        self._notices: list[tuple[str, str]] = []
        self._budget_reported = False

    # -- run-time changes -----------------------------------------------------------------------
    def reconfigure(self, config: TebConfig) -> None:
        """TEB's dynamic_reconfigure: every parameter its spec lets change while running is read from
        ``self.cfg``'s sections where it is used, so copying it into them (in place) takes effect in the
        next cycle; the bands are kept. The footprint model and the topics stay (restart-only)."""
        for name, spec in fields_of(TebConfig).items():
            if spec.dynamic:
                set_value(self.cfg, name, value_of(config, name))
        self.failure_detector.set_buffer_length(buffer_length(self.cfg.recovery.oscillation_filter_duration,
                                                              self.controller_period))

    def set_controller_period(self, controller_period: float) -> None:
        """A new controller_frequency: the acceleration window, the cycle budget and the oscillation
        detector's window (in commands) follow it."""
        if not controller_period > 0:
            raise ValueError(f"controller_period must be > 0, got {controller_period}")
        self.controller_period = float(controller_period)
        self.failure_detector.set_buffer_length(buffer_length(self.cfg.recovery.oscillation_filter_duration,
                                                              self.controller_period))

    def set_costmap_footprint(self, costmap_footprint) -> None:
        """The local costmap's padded footprint changed: the feasibility check uses the new one."""
        self.costmap_footprint = np.asarray(costmap_footprint, dtype=float).reshape(-1, 2)
        self.costmap_inscribed_radius = footprint_radii(self.costmap_footprint)[0]
        self.collision_model = collision_model(self.costmap_footprint, self.costmap_inscribed_radius)

    # -- inputs -------------------------------------------------------------------------------
    def set_plan(self, global_plan_xyyaw) -> None:
        plan = np.asarray(global_plan_xyyaw, dtype=float)
        if plan.ndim != 2 or plan.shape[1] != 3 or len(plan) == 0:
            raise ValueError(f"global plan must be a non-empty (N, 3) array of x, y, yaw; got shape {plan.shape}")
        self.global_plan = plan.copy()
        self.goal_reached = False

    def move_plan(self, global_plan_xyyaw) -> None:
        """The same plan seen anew in the planning frame, because the plan's frame moved against it (map -> odom,
        as a localizer corrects the odometry); unlike set_plan it keeps whether the goal was reached."""
        self.global_plan = np.asarray(global_plan_xyyaw, dtype=float).copy()

    def set_dynamic_obstacles(self, obstacles: np.ndarray, covariance: np.ndarray | None = None) -> None:
        """Moving obstacles for the next cycles, until replaced: (K, 5) rows x, y, vx, vy, radius
        in the planning frame (the local costmap's), positions at the time of the coming control
        cycle, velocities in m/s; (0, 5) for none; covariance: None or (K, 4, 4) over x, y, vx, vy
        (the tracker's filter; zeros from a source that gives none) (docs/reference.md §4.8). Rows with
        a non-finite value, a negative radius or a covariance that is not one are dropped, which is
        reported once."""
        rows, cov, dropped = checked_dynamic_obstacles(obstacles, covariance)
        if dropped and not self._dropped_dynamic_reported:
            self._dropped_dynamic_reported = True
            self._notices.append(("warn", f"TEB: dropped {dropped}. Reported once; later occurrences are not "
                                  "logged."))
        self._next_dynamic_obstacles, self._next_dynamic_covariance = rows, cov

    def reset(self) -> None:
        """Drop every band (recovery behaviours and new goals start from the plan again), and the
        commands and turning preference of the oscillation recovery, which belong to the old
        situation."""
        self.planner.clear()
        self.failure_detector.clear()
        self._last_command = (0.0, 0.0)
        self._since_oscillation = math.inf
        self._set_preferred_rotdir(RotType.none)

    # -- the control cycle --------------------------------------------------------------------
    def pop_notices(self) -> list[tuple[str, str]]:
        """Messages for the log since the last call, as (level, message); each event is reported
        once, not every cycle it lasts."""
        notices, self._notices = self._notices, []
        return notices

    def compute_velocity_commands(self, robot_pose, robot_velocity, costmap) -> VelocityCommandResult:
        cfg = self.cfg
        budget = CYCLE_BUDGET_FRACTION * self.controller_period
        deadline = time.perf_counter() + budget
        pose = np.asarray(robot_pose, dtype=float)
        vel = (float(robot_velocity[0]), float(robot_velocity[1]))
        if len(self.global_plan) == 0:
            return VelocityCommandResult(0.0, 0.0, False, "no global plan set")
        self._prune_global_plan(pose)
        self._since_infeasible += self.controller_period
        self._since_oscillation += self.controller_period
        transformed, goal_idx = self._shrink_horizon(*self._transform_global_plan(pose, costmap))
        self.via_points = self._via_points(transformed)
        if self.is_goal_reached(pose, vel):
            self.goal_reached = True
            return VelocityCommandResult(0.0, 0.0, True, "goal reached", goal_reached=True)
        if cfg.recovery.oscillation_recovery:
            self._oscillation_recovery(vel[1])
        elif self.preferred_rotdir != RotType.none:
            self._set_preferred_rotdir(RotType.none)
            self._notices.append(("info", "TEB: oscillation recovery disabled"))
        local_goal = transformed[-1].copy()
        if cfg.trajectory.global_plan_overwrite_orientation:
            local_goal[2] = self._estimate_local_goal_orientation(local_goal, goal_idx)
        if len(transformed) == 1:
            transformed = np.vstack([pose, transformed])
        transformed[0] = pose
        transformed[-1] = local_goal
        self.transformed_plan = transformed
        lethal = (costmap_point_obstacles(costmap, pose, math.inf)
                  if cfg.obstacles.include_costmap_obstacles else np.zeros((0, 2)))
        self.obstacles = lethal[behind_robot_filter(lethal, pose, cfg.obstacles.costmap_obstacles_behind_robot_dist)]
        self.dynamic_obstacles = self._next_dynamic_obstacles
        moving = planned_motion(self.dynamic_obstacles, cfg.obstacles.include_dynamic_obstacles,
                                self._next_dynamic_covariance, cfg.moving_obstacles.dynamic_obstacle_uncertainty_sigmas)
        prediction = motion_prediction(cfg)
        bounds = (costmap.origin_x, costmap.origin_y,
                  costmap.origin_x + costmap.size_x * costmap.resolution,
                  costmap.origin_y + costmap.size_y * costmap.resolution)
        planned = self.planner.plan(transformed, self.obstacles, self.via_points, vel, cfg.goal_tolerance.free_goal_vel,
                                    bounds, class_obstacles=lethal, deadline=deadline, dynamic_obstacles=moving)
        if self.planner.postponed and not self._budget_reported:
            self._budget_reported = True
            self._notices.append(("warn",
                f"TEB: a control cycle used up its budget ({budget * 1000:.0f} ms, {CYCLE_BUDGET_FRACTION:.0%} of "
                f"controller_period) before the homotopy alternatives were optimised; {self.planner.postponed} "
                "alternative band(s) postponed to the next cycle. The followed band is always optimised. "
                "Reported once; later occurrences are not logged."))
        if not planned:
            return self._infeasible("planner failed to find a trajectory")

        def feasible(band):
            return is_trajectory_feasible(costmap, self.costmap_footprint, self.costmap_inscribed_radius,
                                          band.poses, cfg.trajectory.feasibility_check_no_poses,
                                          cfg.trajectory.feasibility_check_lookahead_distance,
                                          cfg.trajectory.min_resolution_collision_check_angular,
                                          band.time_stamps, moving, self.collision_model, prediction)

        horizon = cfg.moving_obstacles.dynamic_obstacle_evasion_horizon
        evading = cfg.obstacles.include_dynamic_obstacles and horizon > 0 and len(moving) > 0
        if not self.planner.remove_infeasible_best(feasible):
            evasion = self._evasion(pose, vel, local_goal, moving, costmap, prediction) if evading else None
            if evasion is None or not (evasion.standstill_contact_time < horizon
                                       and evasion.contact_time > evasion.standstill_contact_time + MIN_GAIN_S):
                return self._infeasible("trajectory is not feasible. Resetting planner...")
            self._drop_bands()
            return self._command(evasion.v, evasion.omega, vel)
        self._infeasible_in_a_row = 0
        command = velocity_from_band(self.planner.best_band(), cfg)
        if command is None:
            return self._infeasible("velocity command invalid. Resetting planner...")
        if evading:
            band = self.planner.best_band()
            met = band_contact_time(self.collision_model, band.poses, band.time_stamps, moving, horizon, prediction)
            if met < math.inf:
                evasion = self._evasion(pose, vel, local_goal, moving, costmap, prediction)
                if evasion.contact_time > met + MIN_GAIN_S:
                    return self._command(evasion.v, evasion.omega, vel)
        return self._command(*command, vel)

    def _command(self, v: float, omega: float, vel) -> VelocityCommandResult:
        """The command held to the acceleration window and the limits, remembered for the oscillation check."""
        v, omega = saturate(v, omega, vel, self.cfg, self.controller_period)
        self._last_command = (v, omega)
        return VelocityCommandResult(v, omega, True, "")

    def _evasion(self, pose, vel, local_goal, moving, costmap, prediction):
        robot = self.cfg.robot
        limits = (robot.max_vel_x, robot.max_vel_x_backwards, robot.max_vel_theta, robot.acc_lim_x, robot.acc_lim_theta)
        return choose_evasion(pose, vel, local_goal, moving, costmap, self.costmap_footprint, self.collision_model,
                              limits, self.cfg.moving_obstacles.dynamic_obstacle_evasion_horizon, prediction)

    def _infeasible(self, message: str) -> VelocityCommandResult:
        """No valid command this cycle."""
        self._drop_bands()
        return VelocityCommandResult(0.0, 0.0, False, message)

    def _drop_bands(self) -> None:
        """The band was infeasible: drop the bands and count it for shrink_horizon_backup."""
        self.planner.clear()
        self._infeasible_in_a_row += 1
        self._since_infeasible = 0.0
        self._last_command = (0.0, 0.0)

    def is_goal_reached(self, robot_pose, robot_velocity) -> bool:
        """Position and yaw within tolerance, no via-points left (complete_global_plan) and
        stopped by odometry unless free_goal_vel."""
        tolerance = self.cfg.goal_tolerance
        if len(self.global_plan) == 0:
            return False
        goal = self.global_plan[-1]
        x, y, yaw = robot_pose
        v, omega = robot_velocity
        stopped = abs(omega) <= tolerance.theta_stopped_vel and abs(v) <= tolerance.trans_stopped_vel
        return (math.hypot(goal[0] - x, goal[1] - y) < tolerance.xy_goal_tolerance
                and abs(float(normalize_theta(goal[2] - yaw))) < tolerance.yaw_goal_tolerance
                and (not tolerance.complete_global_plan or len(self.via_points) == 0)
                and (stopped or tolerance.free_goal_vel))

    # -- accessors for visualisation ----------------------------------------------------------
    @property
    def band_poses(self) -> np.ndarray:
        band = self.planner.best_band()
        return band.poses.copy() if band is not None else np.zeros((0, 3))

    @property
    def band_time_stamps(self) -> np.ndarray:
        band = self.planner.best_band()
        return band.time_stamps if band is not None else np.zeros(0)

    @property
    def candidate_bands(self) -> list[np.ndarray]:
        """Poses of every homotopy candidate (the best one included)."""
        return [c.band.poses.copy() for c in self.planner.candidates]

    def footprint_outlines(self) -> list[list[np.ndarray]]:
        return self.model.outline(self.band_poses)

    # -- plan handling ------------------------------------------------------------------------
    def _prune_global_plan(self, pose) -> None:
        """Erase the plan before the first pose within global_plan_prune_distance of the robot."""
        d2 = (self.global_plan[:, 0] - pose[0]) ** 2 + (self.global_plan[:, 1] - pose[1]) ** 2
        near = np.nonzero(d2 < self.cfg.trajectory.global_plan_prune_distance ** 2)[0]
        if len(near) and near[0] > 0:
            self.global_plan = self.global_plan[near[0]:]

    def _transform_global_plan(self, pose, costmap):
        """From the plan pose closest to the robot, up to max_global_plan_lookahead_dist of path
        and within 85 % of half the local costmap size. Returns (plan, index of its last pose)."""
        plan = self.global_plan
        threshold = 0.85 * max(costmap.size_x * costmap.resolution / 2.0,
                               costmap.size_y * costmap.resolution / 2.0)
        d2 = (plan[:, 0] - pose[0]) ** 2 + (plan[:, 1] - pose[1]) ** 2
        outside = np.nonzero(d2 > threshold ** 2)[0]
        stop = outside[0] if len(outside) else len(plan)
        if stop == 0:
            return plan[-1:].copy(), len(plan) - 1
        start = int(np.argmin(d2[:stop]))
        # TEB's loop adds pose k+1 only while pose k was inside the threshold and the path length
        # accumulated up to pose k (counting the segment into the first pose) is within the lookahead.
        idx = np.arange(start, len(plan))
        ok = d2[idx] <= threshold ** 2
        max_len = self.cfg.trajectory.max_global_plan_lookahead_dist
        if max_len > 0:
            seg = np.hypot(plan[idx, 0] - plan[idx - 1, 0], plan[idx, 1] - plan[idx - 1, 1])
            seg[idx == 0] = 0.0
            ok &= np.cumsum(seg) <= max_len
        lead = int(np.argmin(ok)) if not ok.all() else len(ok)
        end = min(start + 1 + lead, len(plan))
        return plan[start:end].copy(), end - 1

    def _shrink_horizon(self, transformed, goal_idx: int):
        """shrink_horizon_backup (TEB's configureBackupModes): while cycles fail, and for
        shrink_horizon_min_duration after the last failure, the local goal moves half-way towards
        the robot (counted in plan poses), so a band that keeps running into an obstacle beyond a
        corner is replaced by a shorter one. Not when the local goal is the global goal, whose
        heading must not change under the band."""
        recovery = self.cfg.recovery
        if not (recovery.shrink_horizon_backup and goal_idx < len(self.global_plan) - 1
                and (self._infeasible_in_a_row > 0 or self._since_infeasible < recovery.shrink_horizon_min_duration)):
            return transformed, goal_idx
        reduction = goal_idx // 2
        keep = len(transformed) - reduction
        if keep < 1:
            return transformed, goal_idx
        return transformed[:keep], goal_idx - reduction

    def _oscillation_recovery(self, measured_omega: float) -> None:
        """oscillation_recovery (TEB's configureBackupModes): when the commands of the last
        oscillation_filter_duration oscillate, the optimiser prefers the direction the robot turns
        in now, so the band stops flipping between two ways round an obstacle; the preference is
        kept while the oscillation lasts and for oscillation_recovery_min_duration after it."""
        robot, recovery = self.cfg.robot, self.cfg.recovery
        v, omega = self._last_command
        oscillating = self.failure_detector.update(v, omega, robot.max_vel_x, robot.max_vel_x_backwards,
                                                   robot.max_vel_theta, recovery.oscillation_v_eps,
                                                   recovery.oscillation_omega_eps)
        recently = self._since_oscillation < recovery.oscillation_recovery_min_duration
        if oscillating:
            if not recently:
                rotdir = RotType.left if measured_omega > 0 else RotType.right
                self._notices.append(("warn", "TEB: possible oscillation (of the robot or its local plan) detected; "
                                      f"preferring to turn {rotdir.name} for "
                                      f"{recovery.oscillation_recovery_min_duration:g} s"))
                self._set_preferred_rotdir(rotdir)
            self._since_oscillation = 0.0
        elif not recently and self.preferred_rotdir != RotType.none:
            self._set_preferred_rotdir(RotType.none)
            self._notices.append(("info", "TEB: oscillation recovery expired"))

    def _set_preferred_rotdir(self, rotdir: RotType) -> None:
        self.preferred_rotdir = rotdir
        self.planner.set_preferred_turning_dir(rotdir)

    def _via_points(self, transformed) -> np.ndarray:
        sep = self.cfg.trajectory.global_plan_viapoint_sep
        if sep <= 0:
            return np.zeros((0, 2))
        out, prev = [], transformed[0, :2]
        for p in transformed[1:, :2]:
            if math.hypot(*(p - prev)) >= sep:
                out.append(p)
                prev = p
        return np.array(out).reshape(-1, 2)

    def _estimate_local_goal_orientation(self, local_goal, goal_idx: int) -> float:
        """Near the global goal use its yaw; otherwise average the plan direction over the next
        few poses after the local goal."""
        plan = self.global_plan
        n = len(plan)
        if goal_idx > n - GOAL_ORIENTATION_AVERAGE - 2:
            return float(plan[-1, 2]) if goal_idx < n - 1 else float(local_goal[2])
        length = min(GOAL_ORIENTATION_AVERAGE, n - goal_idx - 1)
        pts = plan[goal_idx:goal_idx + length + 1, :2]
        d = np.diff(pts, axis=0)
        ang = np.arctan2(d[:, 1], d[:, 0])
        return float(math.atan2(np.sin(ang).mean(), np.cos(ang).mean()))
