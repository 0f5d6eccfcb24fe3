"""``--set NAME=VALUE``: move_base parameters from the command line, checked as the parameter files are; and
``max_speed:=V``, which derives the speed-dependent ones (move_base/speed_profile.py) before them.

NAME is a move_base parameter by its ROS 2 name (``TebLocalPlannerROS.max_vel_x``,
``local_costmap.inflation_layer.inflation_radius``); VALUE is read as YAML. Each assignment goes
through the parameter layer (type, range, NaN, unknown names with the closest one), then the whole
tree is checked as move_base would build it. Later assignments win.
"""

from __future__ import annotations

from simplebot_description import robot_description

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.parameter_tree import apply_move_base_overrides
from simplebot_navigation.move_base.speed_profile import speed_parameters
from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.parameters.ros2 import to_ros2_overrides
from simplebot_navigation.launch.loader import LaunchConfig, LaunchError

NODE = "move_base"
LOCAL_PLANNER_KEY, CROWD_PLANNER_KEY = "base_local_planner", "crowd_local_planner"


def apply_set(config: LaunchConfig, assignments: list[str]) -> None:
    """Apply --set assignments to the launch's move_base nodes, every robot's (their ROS 1 trees and ROS 2 parameters);
    LaunchError names what was wrong. What move_base warns about, it logs itself when it starts."""
    if not assignments:
        return
    specs = [node for node in config.nodes if node.name == NODE]
    if not specs:
        raise LaunchError(f"--set: {config.file} starts no {NODE} node")
    for spec in specs:                     # every robot's move_base (multi_navigation)
        tree = config.params.get(spec.full_name, {})
        try:
            tree, _ = apply_move_base_overrides(tree if isinstance(tree, dict) else {}, assignments)
            flat = to_ros2_overrides(tree, where=spec.full_name + "/")
        except ParameterError as err:
            raise LaunchError(f"--set: {err}") from None
        config.params.set(spec.full_name, tree)
        spec.parameters = {**flat, **{k: v for k, v in spec.parameters.items() if k == "use_sim_time"}}


def speed_assignments(config: LaunchConfig, explicit: list[str]) -> tuple[list[str], list[str]]:
    """The --set assignments ``max_speed:=V`` stands for (none without it), and the report: what it derived, and
    which explicit --set replaces a derived value. LaunchError for a value that is not a speed it takes."""
    value = config.args.get("max_speed", "")
    if not value:
        return [], []
    specs = [node for node in config.nodes if node.name == NODE]
    if not specs:
        return [], []          # the simulator alone: only its drive follows max_speed
    try:
        speed = float(value)
    except ValueError:
        raise LaunchError(f"max_speed:={value!r} is not a number of m/s") from None
    tree = config.params.get(specs[0].full_name, {})
    teb = tree.get("TebLocalPlannerROS", {}) if isinstance(tree, dict) else {}
    viapoints_on = isinstance(teb, dict) and float(teb.get("global_plan_viapoint_sep", -0.1) or -0.1) > 0
    replaced = {a.partition("=")[0].strip(): a.partition("=")[2].strip() for a in explicit}
    selected = replaced.get(LOCAL_PLANNER_KEY)
    planner = selected if selected is not None else (tree.get(LOCAL_PLANNER_KEY) if isinstance(tree, dict) else None)
    crowd = replaced.get(CROWD_PLANNER_KEY, tree.get(CROWD_PLANNER_KEY, MoveBaseConfig().crowd_local_planner)
                         if isinstance(tree, dict) else None)
    try:
        derived = speed_parameters(speed, viapoints_on, *([str(planner)] if planner else []),
                                   wheel_separation=_wheel_separation(config), crowd_planner=str(crowd or ""))
    except ValueError as err:       # ParameterError too: an unknown planner type
        raise LaunchError(str(err)) from None
    report = [f"max_speed {speed:g} m/s: " + ", ".join(f"{name}={_shown(v)}" for name, v in derived.items())]
    report += [f"--set {name}={replaced[name]} replaces max_speed's {_shown(derived[name])}"
               for name in derived if name in replaced]
    # a planner chosen by --set is chosen first, so that its derived parameters exist when they are set
    chosen = [f"{key}={replaced[key]}" for key in (LOCAL_PLANNER_KEY, CROWD_PLANNER_KEY) if key in replaced]
    return chosen + [f"{name}={v!r}" for name, v in derived.items()], report


def _wheel_separation(config: LaunchConfig) -> float | None:
    """The wheel separation of the body the launch's robot:= and radius:= describe; None for a launch without
    them or with values the simulator refuses (it says why)."""
    try:
        return robot_description(config.args.get("robot", "box"),
                                 float(config.args.get("radius", "0.3"))).wheel_separation
    except ValueError:
        return None


def _shown(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)
