"""The robot's pose as one control cycle of move_base sees it, looked up once at the cycle's start.

The planner, the controller, the recoveries and the feedback of a cycle all use these poses, so they agree on where
the robot is and TF is searched once per frame per cycle, not once per user.
"""

from __future__ import annotations


class CyclePoses:
    """The robot pose in the global costmap's frame (``in_global``) and in the local costmap's (``in_local``, the
    same object when both costmaps use one frame, base and transform tolerance), as costmap_ros.RobotPose, or None
    with the reason in the costmap's ``last_pose_error``; ``read()`` takes them anew."""

    def __init__(self, global_costmap, local_costmap):
        self.global_costmap, self.local_costmap = global_costmap, local_costmap
        self.in_global = self.in_local = None

    def _shared(self) -> bool:
        g, l = self.global_costmap, self.local_costmap
        return (g.global_frame, g.robot_base_frame, g.transform_tolerance) == \
            (l.global_frame, l.robot_base_frame, l.transform_tolerance)

    def read(self):
        """Look the poses up by the latest TF; returns the global one."""
        self.in_global = self.global_costmap.get_robot_pose()
        self.in_local = self.in_global if self._shared() else self.local_costmap.get_robot_pose()
        return self.in_global

    def of(self, costmap_ros):
        """This cycle's pose in one of the two costmaps' frames."""
        return self.in_global if costmap_ros is self.global_costmap else self.in_local
