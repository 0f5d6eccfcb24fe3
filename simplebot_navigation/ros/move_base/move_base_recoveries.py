"""What move_base's recovery behaviours act on: its costmaps, as move_base/recovery/'s RecoveryContext."""

from __future__ import annotations

import numpy as np

from simplebot_navigation.costmap.footprint import footprint_costs
from simplebot_navigation.geometry import inverse_transform_points, transform_points
from simplebot_navigation.move_base.recovery import PoseTrail
from simplebot_navigation.move_base.recovery.spin import free_area_left_right
from simplebot_navigation.ros.move_base.cycle_poses import CyclePoses


class MoveBaseRecoveryContext:
    """The RecoveryContext of a move_base node: footprint checks and free space on its local costmap, clearing on
    both, the pose trail its control cycle records. The robot's poses are the control cycle's (``poses``), the
    cycle that steps the recoveries and behaviours; ``given`` is the node's parameter tree as the launcher gave it."""

    def __init__(self, poses: CyclePoses, trail: PoseTrail, given: dict, conservative_reset_dist: float):
        self.poses = poses
        self.global_costmap, self.local_costmap = poses.global_costmap, poses.local_costmap
        self.trail = trail
        self.costmaps = {"global": self.global_costmap, "local": self.local_costmap}
        self.conservative_reset_dist = conservative_reset_dist
        self._given = given

    @property
    def circumscribed_radius(self) -> float:
        return self.local_costmap.circumscribed_radius

    def planner_parameters(self, namespace: str) -> dict:
        given = self._given.get(namespace, {})
        return given if isinstance(given, dict) else {}

    def _in_local_frame(self, poses: np.ndarray) -> np.ndarray | None:
        """Poses given in the global costmap's frame (as move_base steps recoveries), moved into the local
        costmap's by where each costmap saw the robot this cycle; None without both poses."""
        if self.local_costmap.global_frame == self.global_costmap.global_frame:
            return poses
        here, there = self.poses.in_global, self.poses.in_local
        if here is None or there is None:
            return None
        return transform_points(there[:3], inverse_transform_points(here[:3], poses))

    def footprint_clear(self, poses: np.ndarray) -> np.ndarray:
        """Per pose: no lethal or unknown cell on the footprint's outline; all False when the poses cannot be
        placed on the local costmap."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        placed = self._in_local_frame(poses)
        if placed is None:
            return np.zeros(len(poses), dtype=bool)
        local = self.local_costmap
        with local.lock:
            return footprint_costs(local.costmap, local.footprint, placed) >= 0

    def free_space(self, pose, radius: float) -> tuple[float, float]:
        placed = self._in_local_frame(np.asarray([pose], dtype=float))
        if placed is None:
            return 0.0, 0.0
        local = self.local_costmap
        with local.lock:
            return free_area_left_right(local.costmap, placed[0], radius)

    def clear_costmap(self, costmap_ros, x, y, reset_distance, layer_names, invert, force_updating) -> list[str]:
        """Clear around the robot's pose of this cycle in this costmap (the given x, y when it has none)."""
        pose = self.poses.of(costmap_ros)
        if pose is not None:
            x, y = pose[0], pose[1]
        with costmap_ros.lock:
            cleared = costmap_ros.clear_layers_outside(x, y, reset_distance, layer_names, invert)
        if force_updating:
            costmap_ros.update_map_now()
        return [f"{costmap_ros.name}/{name}" for name in cleared]
