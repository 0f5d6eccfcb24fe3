"""The recovery behaviours of a move_base node, built over its costmaps.

Each factory takes the node, the behaviour's name and its private parameters, as pluginlib would
construct and initialise a ROS 1 recovery; ros/plugins.py maps the type strings to them.
"""

from __future__ import annotations

import numpy as np

from simplebot_navigation.costmap.footprint import footprint_costs
from simplebot_navigation.geometry import inverse_transform_points, transform_points
from simplebot_navigation.move_base.recovery import (BackUpRecovery, ClearCostmapRecovery, RotateRecovery, SpinRecovery,
                                                     free_area_left_right)
from simplebot_navigation.ros.params import given_parameter_tree

#: rotate_recovery reads these from the (ROS 1 default) local planner's namespace when it has none
ROTATE_BORROWED = ("acc_lim_theta", "max_vel_theta", "min_in_place_vel_theta", "yaw_goal_tolerance")
#: spin_recovery weighs the free area within this many circumscribed radii on either side
SPIN_FREE_SPACE_RADII = 2.0


def _in_local_frame(node, poses: np.ndarray) -> np.ndarray | None:
    """Poses given in the global costmap's frame (as move_base steps recoveries), moved into the local
    costmap's by where each costmap sees the robot now; None without both poses."""
    if node.local_costmap.global_frame == node.global_costmap.global_frame:
        return poses
    here, there = node.global_costmap.get_robot_pose(), node.local_costmap.get_robot_pose()
    if here is None or there is None:
        return None
    return transform_points(there[:3], inverse_transform_points(here[:3], poses))


def _footprint_clear(node):
    """Per pose: the local costmap's footprint check passes (no lethal or unknown cell on the outline);
    all False when the poses cannot be placed on it."""
    local = node.local_costmap

    def clear(poses: np.ndarray) -> np.ndarray:
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        placed = _in_local_frame(node, poses)
        if placed is None:
            return np.zeros(len(poses), dtype=bool)
        with local.lock:
            return footprint_costs(local.costmap, local.footprint, placed) >= 0

    return clear


def rotate_recovery(node, name: str, params: dict) -> RotateRecovery:
    borrowed = given_parameter_tree(node).get("TrajectoryPlannerROS", {})
    params = {**{k: borrowed[k] for k in ROTATE_BORROWED if k in borrowed}, **params}
    return RotateRecovery(name, params, _footprint_clear(node))


def backup_recovery(node, name: str, params: dict) -> BackUpRecovery:
    return BackUpRecovery(name, params, _footprint_clear(node), node.trail)


def spin_recovery(node, name: str, params: dict) -> SpinRecovery:
    local = node.local_costmap

    def free_space(pose) -> tuple[float, float]:
        placed = _in_local_frame(node, np.asarray([pose], dtype=float))
        if placed is None:
            return 0.0, 0.0
        with local.lock:
            return free_area_left_right(local.costmap, placed[0],
                                        SPIN_FREE_SPACE_RADII * local.circumscribed_radius)

    return SpinRecovery(name, params, _footprint_clear(node), free_space)


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
