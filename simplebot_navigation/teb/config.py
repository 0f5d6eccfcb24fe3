"""TebConfig: the TebLocalPlannerROS parameters with teb_local_planner's effective defaults.

The effective defaults are the dynamic_reconfigure cfg values (docs/reference.md §0.1, §4.2), not
the C++ constructor values, because the reconfigure server overwrites every unset parameter.
Each field is declared once, with unit, doc, range and status (simplebot_navigation.parameters).
The parameters are grouped into sections as teb_config.h groups them (``cfg.robot.max_vel_x``,
``cfg.optim.weight_obstacle``); their names stay flat, as in the YAML files and the ROS 2 parameters.
The classes have slots, so setting a parameter on the wrong object (``cfg.max_vel_x = ...``) fails
instead of doing nothing; by name, use simplebot_navigation.parameters' value_of and set_value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from simplebot_navigation.parameters import ParameterError, build, param, section
from simplebot_navigation.perception.prediction import KeepOutGrowth

#: physical bounds of a velocity limit: the fastest drive this stack is built for (a 2 m/s Jackal-class base;
#: the simulated box reaches 1.05 m/s and about 4.5 rad/s); beyond them a limit is a typing error, not a robot
MAX_DRIVE_SPEED = 2.0
MAX_DRIVE_TURN_RATE = 6.0
_HOLONOMIC = "holonomic motion (vy) is not modelled"
_CAR_LIKE = "car-like kinematics are not modelled (diff-drive edges are used)"
_HCP = "the simplified homotopy planner seeds bands left and right of obstacle clusters (teb/homotopy.py)"
_PROXIMITY = "the speed is not scaled down near obstacles"
_CONVERTER = ("costmap cells are used as point obstacles; moving obstacles come from move_base's obstacle "
              "tracker on the obstacles topic")
_LEGACY = "the left/right closest obstacle association is used"


@dataclass(slots=True)
class Trajectory:
    """The band: its resolution and size, the plan slice it follows, the feasibility check, the commanded pose."""
    teb_autosize: bool = param(True, "", "resize the band (add/remove poses) during optimisation")
    dt_ref: float = param(0.3, "s", "desired time between two band poses", gt=0)
    dt_hysteresis: float = param(0.1, "s", "hysteresis around dt_ref before resizing", ge=0)
    min_samples: int = param(3, "", "minimum number of band poses", ge=2)
    max_samples: int = param(500, "", "maximum number of band poses (>= min_samples)", ge=2)
    global_plan_overwrite_orientation: bool = param(True, "", "estimate the local goal's yaw from the plan")
    allow_init_with_backwards_motion: bool = param(False, "", "start a band backwards if the goal lies behind")
    max_global_plan_lookahead_dist: float = param(3.0, "m", "length of the plan slice used as the local goal",
                                                  ge=0)
    global_plan_prune_distance: float = param(1.0, "m", "plan kept behind the robot when pruning", ge=0)
    global_plan_viapoint_sep: float = param(-0.1, "m", "spacing of via-points taken from the plan (< 0: none)")
    via_points_ordered: bool = param(False, "", "visit via-points in the order given")
    force_reinit_new_goal_dist: float = param(1.0, "m", "a goal this far from the last one restarts the band",
                                              ge=0)
    force_reinit_new_goal_angular: float = param(0.78, "rad", "a goal turned this much restarts the band", ge=0)
    feasibility_check_no_poses: int = param(5, "", "band poses checked against the costmap each cycle", ge=0)
    feasibility_check_lookahead_distance: float = param(-1.0, "m", "check poses only up to here (< 0: all)")
    exact_arc_length: bool = param(False, "", "use arc length instead of chord in velocity edges",
                                   not_implemented="velocities use the chord length")
    publish_feedback: bool = param(False, "", "publish the full planner state for debugging",
                                   not_implemented="no feedback topic is published")
    control_look_ahead_poses: int = param(1, "", "band pose whose velocity is commanded", ge=1)
    prevent_look_ahead_poses_near_goal: int = param(0, "", "poses before the goal the look-ahead stops", ge=0)
    min_resolution_collision_check_angular: float = param(math.pi, "rad", "max turn between checked poses",
                                                          gt=0)


@dataclass(slots=True)
class Robot:
    """The robot's velocity and acceleration limits and kinematics."""
    max_vel_x: float = param(0.4, "m/s", "maximum forward speed", gt=0, le=MAX_DRIVE_SPEED)
    max_vel_x_backwards: float = param(0.2, "m/s", "maximum reverse speed", ge=0, le=MAX_DRIVE_SPEED)
    max_vel_y: float = param(0.0, "m/s", "maximum sideways speed", ge=0, not_for_this_robot=_HOLONOMIC)
    max_vel_trans: float = param(0.0, "m/s", "maximum combined speed of a holonomic robot", ge=0,
                                 not_for_this_robot=_HOLONOMIC)
    max_vel_theta: float = param(0.3, "rad/s", "maximum turn rate", gt=0, le=MAX_DRIVE_TURN_RATE)
    acc_lim_x: float = param(0.5, "m/s^2", "maximum linear acceleration", gt=0)
    acc_lim_y: float = param(0.5, "m/s^2", "maximum sideways acceleration", ge=0, not_for_this_robot=_HOLONOMIC)
    acc_lim_theta: float = param(0.5, "rad/s^2", "maximum angular acceleration", gt=0)
    min_turning_radius: float = param(0.0, "m", "minimum turning radius of a car-like robot", ge=0,
                                      not_for_this_robot=_CAR_LIKE)
    wheelbase: float = param(1.0, "m", "axle distance of a car-like robot", not_for_this_robot=_CAR_LIKE)
    cmd_angle_instead_rotvel: bool = param(False, "", "command a steering angle instead of a turn rate",
                                           not_for_this_robot=_CAR_LIKE)
    is_footprint_dynamic: bool = param(False, "", "rebuild the footprint model every cycle",
                                       not_implemented="the footprint model is fixed at start-up")
    use_proportional_saturation: bool = param(False, "", "scale v and omega together when one saturates")
    transform_tolerance: float = param(0.5, "s", "tolerated age of the plan-to-costmap transform", ge=0,
                                       not_implemented="the plan is transformed with the latest transform")


@dataclass(slots=True)
class GoalTolerance:
    """When the goal counts as reached."""
    xy_goal_tolerance: float = param(0.2, "m", "distance to the goal that counts as reached", ge=0)
    yaw_goal_tolerance: float = param(0.1, "rad", "yaw error that counts as reached", ge=0)
    free_goal_vel: bool = param(False, "", "allow a non-zero speed at the goal")
    trans_stopped_vel: float = param(0.1, "m/s", "speed below which the robot counts as stopped", ge=0)
    theta_stopped_vel: float = param(0.1, "rad/s", "turn rate below which the robot counts as stopped", ge=0)
    complete_global_plan: bool = param(True, "", "the goal is reached only after every via-point")


@dataclass(slots=True)
class Obstacles:
    """Which obstacles the optimiser sees and how they are associated with band poses."""
    min_obstacle_dist: float = param(0.5, "m", "minimum distance between footprint model and obstacles", ge=0)
    inflation_dist: float = param(0.6, "m", "buffer zone around obstacles with a small penalty", ge=0)
    dynamic_obstacle_inflation_dist: float = param(0.6, "m", "buffer zone around dynamic obstacles", ge=0)
    include_costmap_obstacles: bool = param(True, "", "take obstacles from the local costmap")
    include_dynamic_obstacles: bool = param(False, "", "predict moving obstacles at constant velocity")
    costmap_obstacles_behind_robot_dist: float = param(1.5, "m", "costmap obstacles kept behind the robot",
                                                       ge=0)
    obstacle_poses_affected: int = param(30, "", "band poses near each obstacle (legacy association)", ge=0,
                                         not_implemented=_LEGACY)
    legacy_obstacle_association: bool = param(False, "", "associate obstacles with their closest poses",
                                              not_implemented=_LEGACY)
    obstacle_association_force_inclusion_factor: float = param(1.5, "", "x min_obstacle_dist: always included",
                                                               ge=0)
    obstacle_association_cutoff_factor: float = param(5.0, "", "x min_obstacle_dist: ignored beyond", ge=0)
    costmap_converter_plugin: str = param("", "", "plugin turning costmap cells into polygons",
                                          not_implemented=_CONVERTER, restart=True)
    costmap_converter_spin_thread: bool = param(True, "", "run the costmap converter in its own thread",
                                                not_implemented=_CONVERTER, restart=True)
    obstacle_proximity_ratio_max_vel: float = param(1.0, "", "speed ratio allowed close to obstacles", ge=0,
                                                    not_implemented=_PROXIMITY)
    obstacle_proximity_lower_bound: float = param(0.0, "m", "distance where the slow-down is full", ge=0,
                                                  not_implemented=_PROXIMITY)
    obstacle_proximity_upper_bound: float = param(0.5, "m", "distance where the slow-down starts", ge=0,
                                                  not_implemented=_PROXIMITY)


@dataclass(slots=True)
class Optimization:
    """The solver's iterations and the weights of its edges."""
    no_inner_iterations: int = param(5, "", "solver iterations per outer iteration", ge=1)
    no_outer_iterations: int = param(4, "", "resize-and-solve rounds per cycle", ge=1)
    optimization_activate: bool = param(True, "", "run the optimiser at all")
    optimization_verbose: bool = param(False, "", "print solver progress",
                                       not_implemented="the solver does not print its progress")
    penalty_epsilon: float = param(0.05, "", "safety margin added to the penalty thresholds", ge=0)
    weight_max_vel_x: float = param(2.0, "", "weight of the forward speed limit", ge=0)
    weight_max_vel_y: float = param(2.0, "", "weight of the sideways speed limit", ge=0,
                                    not_for_this_robot=_HOLONOMIC)
    weight_max_vel_theta: float = param(1.0, "", "weight of the turn rate limit", ge=0)
    weight_acc_lim_x: float = param(1.0, "", "weight of the linear acceleration limit", ge=0)
    weight_acc_lim_y: float = param(1.0, "", "weight of the sideways acceleration limit", ge=0,
                                    not_for_this_robot=_HOLONOMIC)
    weight_acc_lim_theta: float = param(1.0, "", "weight of the angular acceleration limit", ge=0)
    weight_kinematics_nh: float = param(1000.0, "", "weight of the non-holonomic constraint", ge=0)
    weight_kinematics_forward_drive: float = param(1.0, "", "weight against driving backwards", ge=0)
    weight_kinematics_turning_radius: float = param(1.0, "", "weight of the minimum turning radius", ge=0,
                                                    not_for_this_robot=_CAR_LIKE)
    weight_optimaltime: float = param(1.0, "", "weight of the total travel time", ge=0)
    weight_shortest_path: float = param(0.0, "", "weight of the path length", ge=0,
                                        not_implemented="the shortest-path edge is not added")
    weight_obstacle: float = param(50.0, "", "weight of min_obstacle_dist", ge=0)
    weight_inflation: float = param(0.1, "", "weight of inflation_dist", ge=0)
    weight_dynamic_obstacle: float = param(50.0, "", "weight of dynamic obstacle distance", ge=0)
    weight_dynamic_obstacle_inflation: float = param(0.1, "", "weight of dynamic obstacle inflation", ge=0)
    weight_velocity_obstacle_ratio: float = param(0.0, "", "weight of the speed limit near obstacles", ge=0,
                                                  not_implemented=_PROXIMITY)
    weight_viapoint: float = param(1.0, "", "weight of the distance to via-points", ge=0)
    weight_prefer_rotdir: float = param(50.0, "", "weight of the turning direction oscillation recovery prefers",
                                        ge=0)
    weight_adapt_factor: float = param(2.0, "", "factor the obstacle weight grows by per outer iteration", ge=1)
    obstacle_cost_exponent: float = param(1.0, "", "exponent of the obstacle cost (1: linear)", gt=0)


@dataclass(slots=True)
class MovingObstacles(KeepOutGrowth):
    """This stack's additions for moving obstacles (teb_local_planner has no such section): how a predicted
    obstacle's keep-out circle grows with the time ahead (KeepOutGrowth), and the evasion when the band would meet
    one."""
    dynamic_obstacle_evasion_horizon: float = param(2.5, "s", "Here: when the band or a standstill would meet a "
                                                    "predicted moving obstacle within this time, drive the sampled "
                                                    "command that meets one latest (0: stop as TEB does)",
                                                    ge=0, le=10.0)


@dataclass(slots=True)
class HomotopyClasses:
    """Bands in several topological classes and how the followed one is chosen."""
    enable_homotopy_class_planning: bool = param(True, "", "optimise bands in several topological classes")
    enable_multithreading: bool = param(True, "", "optimise the bands in parallel threads",
                                        not_implemented="the bands are optimised one after another")
    simple_exploration: bool = param(False, "", "seed classes from obstacle key points instead of a roadmap",
                                     not_implemented=_HCP)
    max_number_classes: int = param(5, "", "maximum number of bands (classes) kept", ge=1)
    max_number_plans_in_current_class: int = param(1, "", "bands kept in the followed class", ge=1,
                                                   not_implemented=_HCP)
    selection_cost_hysteresis: float = param(1.0, "", "a new class must be this much cheaper to win", ge=0)
    selection_prefer_initial_plan: float = param(0.95, "", "cost factor favouring the initial plan's class",
                                                 ge=0, le=1)
    selection_obst_cost_scale: float = param(2.0, "", "obstacle cost factor when comparing classes", ge=0)
    selection_viapoint_cost_scale: float = param(1.0, "", "via-point cost factor when comparing classes", ge=0)
    selection_alternative_time_cost: bool = param(False, "", "compare classes by time squared")
    selection_dropping_probability: float = param(0.0, "", "chance to drop a class each cycle", ge=0, le=1,
                                                  not_implemented=_HCP)
    switching_blocking_period: float = param(0.0, "s", "minimum time before switching class again", ge=0,
                                             not_implemented=_HCP)
    roadmap_graph_no_samples: int = param(15, "", "roadmap samples per cycle", ge=1, not_implemented=_HCP)
    roadmap_graph_area_width: float = param(5.0, "m", "width of the area where classes are explored", gt=0)
    roadmap_graph_area_length_scale: float = param(1.0, "", "length of the roadmap area per plan length", gt=0,
                                                   not_implemented=_HCP)
    h_signature_prescaler: float = param(1.0, "", "scale of obstacles in the H-signature", gt=0,
                                         not_implemented=_HCP)
    h_signature_threshold: float = param(0.1, "", "H-signatures closer than this are one class", ge=0,
                                         not_implemented=_HCP)
    obstacle_keypoint_offset: float = param(0.1, "m", "offset of key points from obstacles", ge=0,
                                            not_implemented=_HCP)
    obstacle_heading_threshold: float = param(0.45, "", "cosine above which obstacles count as ahead", ge=0,
                                              not_implemented=_HCP)
    viapoints_all_candidates: bool = param(True, "", "give every class the via-points", not_implemented=_HCP)
    visualize_hc_graph: bool = param(False, "", "publish the homotopy roadmap", not_implemented=_HCP)
    delete_detours_backwards: bool = param(True, "", "drop classes that start by turning back")
    detours_orientation_tolerance: float = param(math.pi / 2, "rad", "turn that counts as turning back", ge=0,
                                                 not_implemented=_HCP)
    length_start_orientation_vector: float = param(0.4, "m", "band length that defines its start heading",
                                                   ge=0, not_implemented=_HCP)
    max_ratio_detours_duration_best_duration: float = param(3.0, "", "drop classes this much slower", ge=0)


@dataclass(slots=True)
class Recovery:
    """Shrinking the horizon, and the oscillation recovery."""
    shrink_horizon_backup: bool = param(True, "", "halve the horizon while the band is infeasible")
    shrink_horizon_min_duration: float = param(10.0, "s", "how long the horizon stays halved after that", ge=0)
    oscillation_recovery: bool = param(True, "", "detect oscillation and prefer one turning direction")
    oscillation_v_eps: float = param(0.1, "", "mean |v|/max_vel_x below which the robot oscillates", ge=0)
    oscillation_omega_eps: float = param(0.1, "", "mean |omega|/max_vel_theta below which the robot oscillates",
                                         ge=0)
    oscillation_recovery_min_duration: float = param(10.0, "s", "turning direction kept this long after an "
                                                     "oscillation", ge=0)
    oscillation_filter_duration: float = param(10.0, "s", "window of the oscillation detector", ge=0)
    divergence_detection_enable: bool = param(False, "", "reject solutions whose error diverges",
                                              not_implemented="solver divergence is not detected")
    divergence_detection_max_chi_squared: float = param(10.0, "", "error above which a solution diverged", ge=0,
                                                        not_implemented="solver divergence is not detected")


@dataclass(slots=True)
class TebConfig:
    """All of TebLocalPlannerROS's parameters: the frames and the footprint model here, the rest in sections."""
    odom_topic: str = param("odom", "", "odometry topic the current velocity is read from", restart=True)
    map_frame: str = param("odom", "", "planning frame; as in ROS 1 the local costmap's global_frame is used",
                           restart=True)
    #: the ~footprint_model sub-namespace; teb/footprint.py checks it
    footprint_model: dict = param({}, "", "footprint model: type point, circular, two_circles, line or polygon",
                                  restart=True)
    trajectory: Trajectory = section(Trajectory)
    robot: Robot = section(Robot)
    goal_tolerance: GoalTolerance = section(GoalTolerance)
    obstacles: Obstacles = section(Obstacles)
    optim: Optimization = section(Optimization)
    moving_obstacles: MovingObstacles = section(MovingObstacles)
    hcp: HomotopyClasses = section(HomotopyClasses)
    recovery: Recovery = section(Recovery)
    #: non-fatal findings while loading (unknown keys, parameters without effect)
    warnings: list = field(default_factory=list)

    @classmethod
    def from_params(cls, params: dict[str, Any] | None) -> "TebConfig":
        """Build from the contents of the ``TebLocalPlannerROS`` namespace (nested dict).

        Raises ParameterError (a ValueError) naming the parameter on a bad value; unknown and
        not-implemented keys come back in ``warnings``."""
        cfg, warnings = build(cls, params, "TebLocalPlannerROS")
        cfg.warnings = warnings
        cfg.map_frame = cfg.map_frame.lstrip("/")
        trajectory = cfg.trajectory
        if trajectory.max_samples < trajectory.min_samples:
            raise ParameterError(f"TebLocalPlannerROS/max_samples: must be >= min_samples ({trajectory.min_samples}), "
                                 f"got {trajectory.max_samples}")
        return cfg
