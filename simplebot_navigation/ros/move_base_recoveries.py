"""The recovery behaviours of a move_base node, built over its costmaps.

Each factory takes the node, the behaviour's name and its private parameters, as pluginlib would
construct and initialise a ROS 1 recovery; ros/plugins.py maps the type strings to them.
"""

from __future__ import annotations

import numpy as np

from simplebot_navigation.move_base.recovery import ClearCostmapRecovery, RotateRecovery
from simplebot_navigation.ros.params import given_parameter_tree
from simplebot_navigation.teb.feasibility import footprint_costs

#: rotate_recovery reads these from the (ROS 1 default) local planner's namespace when it has none
ROTATE_BORROWED = ("acc_lim_theta", "max_vel_theta", "min_in_place_vel_theta", "yaw_goal_tolerance")


def rotate_recovery(node, name: str, params: dict) -> RotateRecovery:
    borrowed = given_parameter_tree(node).get("TrajectoryPlannerROS", {})
    params = {**{k: borrowed[k] for k in ROTATE_BORROWED if k in borrowed}, **params}
    local = node.local_costmap

    def footprint_free(poses: np.ndarray) -> bool:
        with local.lock:
            return bool((footprint_costs(local.costmap, local.footprint, poses) >= 0).all())

    return RotateRecovery(name, params, footprint_free)


def clear_costmap_recovery(node, name: str, params: dict) -> ClearCostmapRecovery:
    default_distance = (node.cfg.conservative_reset_dist if name == "conservative_reset"
                        else 4.0 * node.local_costmap.circumscribed_radius)
    costmaps = {"global": node.global_costmap, "local": node.local_costmap}
    return ClearCostmapRecovery(name, params, costmaps, clear_costmap, default_distance)


def clear_costmap(costmap_ros, x, y, reset_distance, layer_names, invert, force_updating) -> list[str]:
    """Clear around the robot's current pose in this costmap (the given x, y when it has none)."""
    pose = costmap_ros.get_robot_pose()
    if pose is not None:
        x, y = pose[0], pose[1]
    with costmap_ros.lock:
        cleared = costmap_ros.clear_layers_outside(x, y, reset_distance, layer_names, invert)
    if force_updating:
        costmap_ros.update_map_now()
    return [f"{costmap_ros.name}/{name}" for name in cleared]
