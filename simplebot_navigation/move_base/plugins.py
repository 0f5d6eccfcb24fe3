"""move_base's plugin types (ROS 1 pluginlib names) and the registry that binds them.

The ROS node binds each type to its implementation in ros/plugins.py; the names live here, below
the ROS layer, so that configuration code can check them too.
"""

from __future__ import annotations

from simplebot_navigation.planning.config import GLOBAL_PLANNER, NAVFN

TEB_LOCAL_PLANNER = "teb_local_planner/TebLocalPlannerROS"
CLEAR_COSTMAP_RECOVERY = "clear_costmap_recovery/ClearCostmapRecovery"
ROTATE_RECOVERY = "rotate_recovery/RotateRecovery"
# Nav2's BackUp and Spin behaviours as move_base recovery behaviours (move_base/recovery.py).
BACKUP_RECOVERY = "backup_recovery/BackUpRecovery"
SPIN_RECOVERY = "spin_recovery/SpinRecovery"

__all__ = ["GLOBAL_PLANNER", "NAVFN", "TEB_LOCAL_PLANNER", "CLEAR_COSTMAP_RECOVERY", "ROTATE_RECOVERY",
           "BACKUP_RECOVERY", "SPIN_RECOVERY", "PluginRegistry", "plugin_namespace"]


class PluginRegistry:
    """The implementations of one move_base parameter's plugin types (base_global_planner, ...)."""

    def __init__(self, parameter: str, implementations: dict):
        self.parameter = parameter
        self._implementations = dict(implementations)

    @property
    def types(self) -> tuple[str, ...]:
        return tuple(self._implementations)

    def resolve(self, plugin_type: str):
        """The class or factory of a type; ValueError naming the known types for any other."""
        try:
            return self._implementations[plugin_type]
        except (KeyError, TypeError):
            raise ValueError(f"{self.parameter}: unknown type {plugin_type!r}; "
                             f"known types: {', '.join(self._implementations)}") from None


def plugin_namespace(plugin_type: str) -> str:
    """A plugin's parameter namespace as ROS 1 move_base derives it: the class name after the '/'."""
    return plugin_type.rpartition("/")[2]
