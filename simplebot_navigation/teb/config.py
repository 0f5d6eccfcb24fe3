"""TebConfig: the TebLocalPlannerROS parameters with teb_local_planner's effective defaults.

The effective defaults are the dynamic_reconfigure cfg values (REFERENCE §0.1, §4.2), not
the C++ constructor values, because the reconfigure server overwrites every unset parameter.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any


@dataclass
class TebConfig:
    # -- trajectory -------------------------------------------------------------
    teb_autosize: bool = True
    dt_ref: float = 0.3
    dt_hysteresis: float = 0.1
    min_samples: int = 3
    max_samples: int = 500
    global_plan_overwrite_orientation: bool = True
    allow_init_with_backwards_motion: bool = False
    max_global_plan_lookahead_dist: float = 3.0
    global_plan_prune_distance: float = 1.0
    global_plan_viapoint_sep: float = -0.1
    via_points_ordered: bool = False
    force_reinit_new_goal_dist: float = 1.0
    force_reinit_new_goal_angular: float = 0.78
    feasibility_check_no_poses: int = 5
    feasibility_check_lookahead_distance: float = -1.0
    exact_arc_length: bool = False
    publish_feedback: bool = False
    control_look_ahead_poses: int = 1
    prevent_look_ahead_poses_near_goal: int = 0
    min_resolution_collision_check_angular: float = math.pi
    # -- robot ------------------------------------------------------------------
    max_vel_x: float = 0.4
    max_vel_x_backwards: float = 0.2
    max_vel_y: float = 0.0
    max_vel_trans: float = 0.0
    max_vel_theta: float = 0.3
    acc_lim_x: float = 0.5
    acc_lim_y: float = 0.5
    acc_lim_theta: float = 0.5
    min_turning_radius: float = 0.0
    wheelbase: float = 1.0
    cmd_angle_instead_rotvel: bool = False
    is_footprint_dynamic: bool = False
    use_proportional_saturation: bool = False
    transform_tolerance: float = 0.5
    odom_topic: str = "odom"
    map_frame: str = "odom"
    # -- goal tolerance ---------------------------------------------------------
    xy_goal_tolerance: float = 0.2
    yaw_goal_tolerance: float = 0.1
    free_goal_vel: bool = False
    trans_stopped_vel: float = 0.1
    theta_stopped_vel: float = 0.1
    complete_global_plan: bool = True
    # -- obstacles --------------------------------------------------------------
    min_obstacle_dist: float = 0.5
    inflation_dist: float = 0.6
    dynamic_obstacle_inflation_dist: float = 0.6
    include_costmap_obstacles: bool = True
    include_dynamic_obstacles: bool = False
    costmap_obstacles_behind_robot_dist: float = 1.5
    obstacle_poses_affected: int = 30
    legacy_obstacle_association: bool = False
    obstacle_association_force_inclusion_factor: float = 1.5
    obstacle_association_cutoff_factor: float = 5.0
    costmap_converter_plugin: str = ""
    costmap_converter_spin_thread: bool = True
    obstacle_proximity_ratio_max_vel: float = 1.0
    obstacle_proximity_lower_bound: float = 0.0
    obstacle_proximity_upper_bound: float = 0.5
    # -- optimisation -----------------------------------------------------------
    no_inner_iterations: int = 5
    no_outer_iterations: int = 4
    optimization_activate: bool = True
    optimization_verbose: bool = False
    penalty_epsilon: float = 0.05
    weight_max_vel_x: float = 2.0
    weight_max_vel_y: float = 2.0
    weight_max_vel_theta: float = 1.0
    weight_acc_lim_x: float = 1.0
    weight_acc_lim_y: float = 1.0
    weight_acc_lim_theta: float = 1.0
    weight_kinematics_nh: float = 1000.0
    weight_kinematics_forward_drive: float = 1.0
    weight_kinematics_turning_radius: float = 1.0
    weight_optimaltime: float = 1.0
    weight_shortest_path: float = 0.0
    weight_obstacle: float = 50.0
    weight_inflation: float = 0.1
    weight_dynamic_obstacle: float = 50.0
    weight_dynamic_obstacle_inflation: float = 0.1
    weight_velocity_obstacle_ratio: float = 0.0
    weight_viapoint: float = 1.0
    weight_prefer_rotdir: float = 50.0
    weight_adapt_factor: float = 2.0
    obstacle_cost_exponent: float = 1.0
    # -- homotopy class planning ------------------------------------------------
    enable_homotopy_class_planning: bool = True
    enable_multithreading: bool = True
    simple_exploration: bool = False
    max_number_classes: int = 5
    max_number_plans_in_current_class: int = 1
    selection_cost_hysteresis: float = 1.0
    selection_prefer_initial_plan: float = 0.95
    selection_obst_cost_scale: float = 2.0
    selection_viapoint_cost_scale: float = 1.0
    selection_alternative_time_cost: bool = False
    selection_dropping_probability: float = 0.0
    switching_blocking_period: float = 0.0
    roadmap_graph_no_samples: int = 15
    roadmap_graph_area_width: float = 5.0
    roadmap_graph_area_length_scale: float = 1.0
    h_signature_prescaler: float = 1.0
    h_signature_threshold: float = 0.1
    obstacle_keypoint_offset: float = 0.1
    obstacle_heading_threshold: float = 0.45
    viapoints_all_candidates: bool = True
    visualize_hc_graph: bool = False
    delete_detours_backwards: bool = True
    detours_orientation_tolerance: float = math.pi / 2
    length_start_orientation_vector: float = 0.4
    max_ratio_detours_duration_best_duration: float = 3.0
    # -- recovery ---------------------------------------------------------------
    shrink_horizon_backup: bool = True
    shrink_horizon_min_duration: float = 10.0
    oscillation_recovery: bool = True
    oscillation_v_eps: float = 0.1
    oscillation_omega_eps: float = 0.1
    oscillation_recovery_min_duration: float = 10.0
    oscillation_filter_duration: float = 10.0
    divergence_detection_enable: bool = False
    divergence_detection_max_chi_squared: float = 10.0
    # -- footprint model (the ~footprint_model sub-namespace, kept raw) -----------
    footprint_model: dict = field(default_factory=dict)
    #: non-fatal findings while loading (unknown keys); the footprint model adds its own.
    warnings: list = field(default_factory=list)

    @classmethod
    def from_params(cls, params: dict[str, Any] | None) -> "TebConfig":
        """Build from the contents of the ``TebLocalPlannerROS`` namespace (nested dict).

        Raises ValueError naming the parameter on a wrongly typed value. Unknown keys are
        kept out and reported in ``warnings`` (ROS would silently ignore them).
        """
        cfg = cls()
        if params is None:
            return cfg
        if not isinstance(params, dict):
            raise ValueError(f"TebLocalPlannerROS parameters must be a mapping, got {type(params).__name__}")
        fields = {f.name: f for f in dataclasses.fields(cls) if f.name not in ("warnings",)}
        for key, value in params.items():
            if key not in fields:
                cfg.warnings.append(f"TebLocalPlannerROS: unknown parameter '{key}' ignored")
                continue
            default = getattr(cfg, key)
            setattr(cfg, key, _coerce(key, value, default))
        cfg.map_frame = cfg.map_frame.lstrip("/")
        _check_ranges(cfg)
        return cfg


def _coerce(key: str, value: Any, default: Any) -> Any:
    def bad(expected: str) -> ValueError:
        return ValueError(f"TebLocalPlannerROS/{key}: expected {expected}, got {value!r} "
                          f"({type(value).__name__})")

    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise bad("a bool")
        return value
    if isinstance(default, int):
        # ROS 1 getParam(int) rounds a double; accept only integral doubles to avoid surprises.
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise bad("an int")
        if isinstance(value, float):
            if not value.is_integer():
                raise bad("an int")
            value = int(value)
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise bad("a number")
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise bad("a string")
        return value
    if isinstance(default, dict):
        if not isinstance(value, dict):
            raise bad("a mapping")
        return dict(value)
    raise bad(type(default).__name__)


def _check_ranges(cfg: TebConfig) -> None:
    positive = ("dt_ref", "max_vel_x", "max_vel_theta", "acc_lim_x", "acc_lim_theta")
    for name in positive:
        if not getattr(cfg, name) > 0:
            raise ValueError(f"TebLocalPlannerROS/{name}: must be > 0, got {getattr(cfg, name)}")
    non_negative = ("dt_hysteresis", "min_obstacle_dist", "penalty_epsilon", "max_vel_x_backwards",
                    "xy_goal_tolerance", "yaw_goal_tolerance")
    for name in non_negative:
        if getattr(cfg, name) < 0:
            raise ValueError(f"TebLocalPlannerROS/{name}: must be >= 0, got {getattr(cfg, name)}")
    if cfg.min_samples < 2:
        raise ValueError(f"TebLocalPlannerROS/min_samples: must be >= 2, got {cfg.min_samples}")
    if cfg.max_samples < cfg.min_samples:
        raise ValueError(f"TebLocalPlannerROS/max_samples: must be >= min_samples ({cfg.min_samples}), "
                         f"got {cfg.max_samples}")
    for name in ("no_inner_iterations", "no_outer_iterations", "max_number_classes"):
        if getattr(cfg, name) < 1:
            raise ValueError(f"TebLocalPlannerROS/{name}: must be >= 1, got {getattr(cfg, name)}")
