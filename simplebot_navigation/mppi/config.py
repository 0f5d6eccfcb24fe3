"""MppiConfig: the MPPILocalPlannerROS parameters (docs/reference.md §4.10).

Names follow Nav2's MPPI controller where one fits (batch_size, time_steps, model_dt, temperature, gamma, vx_max,
ax_min, ...); its critics' ``cost_weight`` parameters are flat here (``path_align_weight`` for PathAlignCritic's,
...), grouped into sections as TebConfig's are. The drive's wheel limits (wheel_speed_max, wheel_separation) and
the moving-obstacle section have no Nav2 counterpart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from simplebot_navigation.parameters import ParameterError, build, param, section
from simplebot_navigation.perception.prediction import KeepOutGrowth

#: the fastest drive this stack is built for (a 2 m/s Jackal-class base, sim/diff_drive.py); beyond these a limit is
#: a typing error, not a robot
MAX_DRIVE_SPEED = 2.0
MAX_DRIVE_TURN_RATE = 6.0
MAX_DRIVE_ACCEL = 10.0


@dataclass(slots=True)
class Sampling:
    """How many control sequences are sampled, how far ahead, and how they are weighed."""
    batch_size: int = param(1000, "", "control sequences sampled per iteration", ge=16, le=5000)
    time_steps: int = param(60, "", "steps of each sampled sequence (time_steps x model_dt is the horizon)",
                            ge=4, le=200)
    model_dt: float = param(0.05, "s", "duration of one step; the controller period suits it best", ge=0.01,
                            le=0.5)
    iteration_count: int = param(1, "", "sample-and-update rounds per control cycle", ge=1, le=10)
    temperature: float = param(0.3, "", "selectiveness of the weighted average: lower follows the cheapest "
                               "samples more closely", gt=0, le=100.0)
    gamma: float = param(0.015, "", "weight of the control cost of the noise, u . eps / std^2 averaged over the "
                         "steps (draws the sequence towards rest)", ge=0, le=1.0)
    vx_std: float = param(0.2, "m/s", "standard deviation of the forward speed noise", ge=0, le=MAX_DRIVE_SPEED)
    wz_std: float = param(0.4, "rad/s", "standard deviation of the turn rate noise", ge=0, le=MAX_DRIVE_TURN_RATE)
    prune_distance: float = param(3.5, "m", "length of the global plan ahead of the robot the critics follow",
                                  gt=0, le=50.0)


@dataclass(slots=True)
class Limits:
    """The motion model: velocity and acceleration limits, and the drive's wheel limit."""
    vx_max: float = param(0.4, "m/s", "maximum forward speed (the lab's TEB max_vel_x)", gt=0, le=MAX_DRIVE_SPEED)
    vx_min: float = param(-0.35, "m/s", "maximum reverse speed, negative (0: never reverse)", ge=-MAX_DRIVE_SPEED,
                          le=0)
    wz_max: float = param(4.0, "rad/s", "maximum turn rate (the wheel limit lowers it at speed)", gt=0,
                          le=MAX_DRIVE_TURN_RATE)
    ax_max: float = param(1.0, "m/s^2", "maximum acceleration away from standstill", gt=0, le=MAX_DRIVE_ACCEL)
    ax_min: float = param(-1.5, "m/s^2", "maximum deceleration, negative: what braking is planned and verified "
                          "with; the drive must brake at least this hard", ge=-MAX_DRIVE_ACCEL, le=-0.05)
    az_max: float = param(3.5, "rad/s^2", "maximum angular acceleration", gt=0, le=4 * MAX_DRIVE_ACCEL)
    wheel_speed_max: float = param(1.05, "m/s", "Here: the drive's top wheel speed at the rim; a velocity whose "
                                   "wheel speeds exceed it is scaled down along its curvature, as the drive does",
                                   gt=0, le=MAX_DRIVE_SPEED)
    wheel_accel_max: float = param(1.75, "m/s^2", "Here: the drive's wheel acceleration at the rim; a step whose "
                                   "wheel speeds would change faster is scaled down, turn and speed together, as the "
                                   "drive ramps its wheels", ge=0.05, le=MAX_DRIVE_ACCEL)
    wheel_separation: float = param(0.46, "m", "Here: distance between the driven wheels (the lab's box and the "
                                    "0.3 m round body; a larger value plans turns more cautiously)", gt=0, le=2.0)


@dataclass(slots=True)
class Critics:
    """The weights of the critics (Nav2's critic in brackets) and their thresholds."""
    path_align_weight: float = param(1.0, "", "mean distance of the rollout to the plan, per metre "
                                     "(PathAlignCritic)", ge=0, le=1000.0)
    path_follow_weight: float = param(3.0, "", "distance from the rollout's end to the plan point it should "
                                      "reach, per metre (PathFollowCritic)", ge=0, le=1000.0)
    path_angle_weight: float = param(1.0, "", "heading away from that plan point, per radian, at the rollout's "
                                     "start (PathAngleCritic)", ge=0, le=1000.0)
    goal_weight: float = param(5.0, "", "mean distance to the goal once it is near, per metre (GoalCritic)",
                               ge=0, le=1000.0)
    threshold_to_consider: float = param(1.4, "m", "within this of the goal the goal critic replaces the path "
                                         "critics", ge=0, le=10.0)
    prefer_forward_weight: float = param(5.0, "", "reverse travel, per metre (PreferForwardCritic)", ge=0,
                                         le=1000.0)
    smoothness_weight: float = param(0.02, "", "mean squared acceleration along the rollout, per (m/s^2)^2 and "
                                     "(rad/s^2)^2 (TwirlingCritic's role)", ge=0, le=1000.0)
    cost_weight: float = param(2.0, "", "mean inflated cost of the local costmap along the rollout, per "
                               "lethal cost (CostCritic); inscribed and lethal cells are infeasible", ge=0,
                               le=1000.0)
    collision_cost: float = param(1000.0, "", "cost of a rollout that meets a lethal or inscribed cell (or "
                                  "a moving obstacle, below)", gt=0, le=1e6)


@dataclass(slots=True)
class MovingObstacles(KeepOutGrowth):
    """Moving obstacles (docs/reference.md §4.8): predicted at constant velocity, their keep-out circles grown as
    TEB's are (KeepOutGrowth); a rollout is judged by its time to collision."""
    moving_obstacle_weight: float = param(1.0, "", "Here: time to collision: a rollout that meets a predicted "
                                          "obstacle at time t costs collision_cost x this x (1 - t / horizon)",
                                          ge=0, le=100.0)
    contact_speed_weight: float = param(50.0, "", "Here: a rollout that meets one anyway, per m/s it is still "
                                        "driving then", ge=0, le=1000.0)
    clearance_weight: float = param(5.0, "", "Here: mean shortfall of the clearance below "
                                    "moving_obstacle_clearance, per metre", ge=0, le=1000.0)
    moving_obstacle_clearance: float = param(0.4, "m", "Here: clearance to a keep-out circle that costs nothing",
                                             ge=0, le=3.0)
    contact_margin: float = param(0.1, "m", "Here: a rollout within this of a keep-out circle meets it", ge=0,
                                  le=1.0)
    unknown_obstacle_speed: float = param(0.5, "m/s", "Here: the passive safety keeps the braking robot as far from "
                                          "the costmap's lethal cells as an obstacle the tracker has not picked up "
                                          "could walk towards it at this speed until the robot is at rest (0: off)",
                                          ge=0, le=MAX_DRIVE_SPEED)
    passive_safety: bool = param(True, "", "Here: verify every command's trajectory and its braking against the "
                                 "predicted obstacles and the costmap, else brake or escape")


@dataclass(slots=True)
class SpaceTimeGuide:
    """The space-time path the rollouts follow (mppi/guide.py): a wavefront over x, y and t against the predicted
    keep-out circles, replanned every few cycles, that chooses the gap and the moment to go through it."""
    space_time_guide: bool = param(True, "", "Here: follow a space-time path through the moving obstacles (false: "
                                   "the global plan ahead, as without moving obstacles)")
    guide_horizon: float = param(6.0, "s", "Here: how far ahead the space-time search looks", ge=1.0, le=15.0)
    guide_step: float = param(0.2, "s", "Here: the search's time step; its cells are as wide as half of what the "
                              "robot travels in one (0.09 m at 0.9 m/s), so its cost does not grow with the speed",
                              ge=0.05, le=1.0)
    guide_period: float = param(0.1, "s", "Here: the search runs again after this long", ge=0.0, le=2.0)
    guide_speed_share: float = param(0.9, "", "Here: the search plans at this share of vx_max (a diff drive must "
                                     "turn before it steps aside)", gt=0, le=1.0)
    guide_clearance: float = param(0.1, "m", "Here: clearance the search keeps from every keep-out circle", ge=0,
                                   le=1.0)
    guide_radius_growth: float = param(0.3, "m/s", "Here: the search's keep-out circles grow this much per second "
                                       "ahead, on top of dynamic_obstacle_radius_growth (where this and "
                                       "guide_clearance close every way, it runs again without both)", ge=0, le=2.0)
    guide_weight: float = param(5.0, "", "Here: mean distance of the rollout from where the space-time path is at "
                                "the same time, per metre", ge=0, le=1000.0)


@dataclass(slots=True)
class GoalTolerance:
    """When the goal counts as reached (Nav2's SimpleGoalChecker)."""
    xy_goal_tolerance: float = param(0.2, "m", "distance to the goal that counts as reached", ge=0.01, le=5.0)
    yaw_goal_tolerance: float = param(0.15, "rad", "yaw error that counts as reached", ge=0.01, le=math.pi)
    trans_stopped_velocity: float = param(0.1, "m/s", "speed below which the robot counts as stopped", ge=0,
                                          le=MAX_DRIVE_SPEED)
    rot_stopped_velocity: float = param(0.2, "rad/s", "turn rate below which the robot counts as stopped",
                                        ge=0, le=MAX_DRIVE_TURN_RATE)


@dataclass(slots=True)
class MppiConfig:
    """All of MPPILocalPlannerROS's parameters."""
    odom_topic: str = param("/odom", "", "odometry topic the current velocity is read from (the lab's launch "
                            "remaps /odom to the drive's)", restart=True)
    sampling: Sampling = section(Sampling)
    limits: Limits = section(Limits)
    critics: Critics = section(Critics)
    moving_obstacles: MovingObstacles = section(MovingObstacles)
    space_time: SpaceTimeGuide = section(SpaceTimeGuide)
    goal_tolerance: GoalTolerance = section(GoalTolerance)
    #: non-fatal findings while loading (unknown keys)
    warnings: list = field(default_factory=list)

    @classmethod
    def from_params(cls, params: dict[str, Any] | None) -> MppiConfig:
        """Build from the contents of the ``MPPILocalPlannerROS`` namespace (nested dict); ParameterError naming
        the parameter on a bad value, unknown keys in ``warnings``."""
        cfg, warnings = build(cls, params, "MPPILocalPlannerROS")
        cfg.warnings = warnings
        limits = cfg.limits
        if limits.vx_max > limits.wheel_speed_max:
            raise ParameterError(f"MPPILocalPlannerROS/vx_max: must be <= wheel_speed_max "
                                 f"({limits.wheel_speed_max:g}), got {limits.vx_max:g}")
        return cfg
