"""The implementations of move_base's plugin types in this node: global planners, local planners and
recovery behaviours, each a PluginRegistry (as costmap/plugins.py is for costmap layers)."""

from __future__ import annotations

from simplebot_navigation.move_base.plugins import (BACKUP_RECOVERY, CLEAR_COSTMAP_RECOVERY, GLOBAL_PLANNER, NAVFN,
                                                    ROTATE_RECOVERY, SPIN_RECOVERY, TEB_LOCAL_PLANNER,
                                                    PluginRegistry)
from simplebot_navigation.ros.global_planner_ros import GlobalPlannerROS
from simplebot_navigation.ros.move_base_recoveries import (backup_recovery, clear_costmap_recovery, rotate_recovery,
                                                           spin_recovery)
from simplebot_navigation.ros.teb_local_planner_ros import TebLocalPlannerROS

GLOBAL_PLANNERS = PluginRegistry("base_global_planner", {GLOBAL_PLANNER: GlobalPlannerROS, NAVFN: GlobalPlannerROS})
LOCAL_PLANNERS = PluginRegistry("base_local_planner", {TEB_LOCAL_PLANNER: TebLocalPlannerROS})
#: factories (node, name, params) -> recovery behaviour
RECOVERY_BEHAVIORS = PluginRegistry("recovery_behaviors", {CLEAR_COSTMAP_RECOVERY: clear_costmap_recovery,
                                                           ROTATE_RECOVERY: rotate_recovery,
                                                           BACKUP_RECOVERY: backup_recovery,
                                                           SPIN_RECOVERY: spin_recovery})


class LocalPlannerAdapter:
    """A node's local planner as MoveBaseCore drives it: plans arrive in the global costmap's frame."""

    def __init__(self, node):
        self.node = node

    def set_plan(self, plan) -> bool:
        return self.node.controller.set_plan(plan, self.node.global_costmap.global_frame)

    def compute(self):
        return self.node.controller.compute()

    def is_goal_reached(self) -> bool:
        return self.node.controller.is_goal_reached()

    def reset(self) -> None:
        self.node.controller.reset()
