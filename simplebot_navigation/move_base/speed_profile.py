"""One speed setting for move_base (docs/reference.md §10): every parameter that has to follow the top speed,
derived from it.

A faster robot needs more than a higher ``max_vel_x``: its turn rate and accelerations must grow with it, or it
crawls through every bend; TEB's poses must stay close together in space, or the band skips over a thin post
between two of them, but not in time, or the acceleration edges take over the band; and it must see far enough
to stop. The rules below keep those in proportion; they
reproduce the 1 m/s set the forest benchmark was tuned with.
"""

from __future__ import annotations

import math

from simplebot_navigation.move_base.plugins import LOCAL_PLANNERS, plugin_namespace
from simplebot_navigation.teb.plugin import TEB_LOCAL_PLANNER

#: the range of top speeds (m/s) the rules are made for: TEB's own speed limit above, a crawl below
MIN_SPEED = 0.1
MAX_SPEED = 2.0
#: the lidars' maximum range (m): nothing beyond it is ever seen
LIDAR_RANGE_M = 5.6
#: from an obstacle coming into view to the robot starting to brake: a scan period, a costmap update and a
#: control period
REACTION_S = 0.25
#: kept free between the stopped robot and the obstacle it stopped for
STOP_MARGIN_M = 0.5
#: TEB's poses at top speed lie this far apart while MIN_DT_REF_S allows: the thinnest posts' diameter
BAND_STEP_M = 0.15
#: the shortest dt_ref: an acceleration edge divides the noise of three poses by dt^2, and below about 0.15 s
#: those edges outweigh the rest of the band, which the optimiser then slows down and folds to satisfy them
#: (forest set at 2 m/s: dt_ref 0.075 s scored 0.353, 0.15 s 0.483, BENCHMARKS.md). At 2 m/s the poses are then
#: 0.3 m apart, still inside the round body's 0.5 m; the feasibility check fills in poses anyway.
MIN_DT_REF_S = 0.15


def stopping_distance(speed: float, decel: float) -> float:
    """Travel from an obstacle coming into view to standing still, plus the margin kept."""
    return speed * REACTION_S + speed * speed / (2.0 * decel) + STOP_MARGIN_M


def _hooked(planner: str, speed: float, wheel_separation: float | None) -> dict[str, float | int]:
    """A local planner's own speed parameters, from its registration's hook (none without one)."""
    hook = LOCAL_PLANNERS.spec(planner).speed_parameters
    return hook(speed, wheel_separation) if hook is not None else {}


def check_speed(speed: float) -> str | None:
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not math.isfinite(speed) \
            or not MIN_SPEED <= speed <= MAX_SPEED:
        return f"max_speed must be a number of m/s in [{MIN_SPEED:g}, {MAX_SPEED:g}], got {speed!r}"
    return None


def speed_parameters(speed: float, viapoints_on: bool, local_planner: str = TEB_LOCAL_PLANNER,
                     wheel_separation: float | None = None, crowd_planner: str | None = None) -> dict[str, float | int]:
    """move_base's parameters (ROS 2 names, as ``--set`` takes them) for a top speed of ``speed`` m/s.
    ``viapoints_on``: the parameter files use TEB's via-points (global_plan_viapoint_sep > 0), whose spacing then
    follows the speed too. TEB's own are derived below; another ``local_planner``'s come from its registration's
    ``speed_parameters`` (none if it has none), which also get the robot's ``wheel_separation`` (m; None: not
    known), and so do the crowd planner's (``crowd_planner``, the one that drives among moving obstacles; None: none).
    ValueError for a speed outside [MIN_SPEED, MAX_SPEED], ParameterError for an unknown planner."""
    problem = check_speed(speed)
    if problem is not None:
        raise ValueError(problem)
    acc = max(0.5, speed)                     # m/s^2: top speed within a second (TEB's default 0.5 at least)
    # TEB's 0.3 s while the poses stay close enough, never below MIN_DT_REF_S
    dt_ref = math.floor(min(0.3, max(MIN_DT_REF_S, BAND_STEP_M / speed)) * 1e4) / 1e4
    stop = stopping_distance(speed, acc)
    # the local costmap (whole metres, as costmap_2d's width): the lab's 5 m, more when stopping needs it
    window = max(5, math.ceil(2.0 * (stop + 1.0)))
    sight = round(min(LIDAR_RANGE_M, window * math.sqrt(0.5)), 3)   # the window's corners
    teb = {
        "max_vel_x": speed,
        "max_vel_x_backwards": max(0.2, 0.25 * speed),
        "max_vel_theta": max(0.3, speed),     # rad/s: a bend of 1 m radius at top speed
        "acc_lim_x": acc,
        "acc_lim_theta": acc,
        "dt_ref": dt_ref,
        "dt_hysteresis": round(dt_ref / 10.0, 5),
        "max_global_plan_lookahead_dist": max(3.0, window / 2.0),
        "feasibility_check_no_poses": math.ceil(stop / (speed * dt_ref)),
    }
    if viapoints_on:
        teb["global_plan_viapoint_sep"] = round(max(0.1, speed * dt_ref), 3)
    if local_planner != TEB_LOCAL_PLANNER:
        teb = _hooked(local_planner, speed, wheel_separation)
    out: dict[str, float | int] = {f"{plugin_namespace(local_planner)}.{key}": value for key, value in teb.items()}
    if crowd_planner and crowd_planner != local_planner:
        out.update({f"{plugin_namespace(crowd_planner)}.{key}": value
                    for key, value in _hooked(crowd_planner, speed, wheel_separation).items()})
    out["local_costmap.width"] = out["local_costmap.height"] = window
    for laser in ("front_laser", "back_laser"):
        out[f"local_costmap.obstacles.{laser}.obstacle_range"] = sight
    out["controller_frequency"] = max(20.0, 10.0 * speed)   # at most 0.1 m driven per control period
    # 30 s at the lab's 0.4 m/s, half that from 0.8 m/s: a fast robot that stalls is noticed sooner, but recoveries
    # must not start while it waits for a way round a cluster of posts
    out["progress_timeout"] = max(15.0, 12.0 / speed)
    return out
