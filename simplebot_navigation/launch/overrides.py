"""``--set NAME=VALUE``: move_base parameters from the command line, checked as the parameter files are.

NAME is a move_base parameter by its ROS 2 name (``TebLocalPlannerROS.max_vel_x``,
``local_costmap.inflation_layer.inflation_radius``); VALUE is read as YAML. Each assignment goes
through the parameter layer (type, range, NaN, unknown names with the closest one), then the whole
tree is checked as move_base would build it. Later assignments win.
"""

from __future__ import annotations

from simplebot_navigation.move_base.parameter_tree import apply_move_base_overrides
from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.parameters.ros2 import to_ros2_overrides
from simplebot_navigation.launch.loader import LaunchConfig, LaunchError

NODE = "move_base"


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
