"""Global planning: global_planner/GlobalPlanner and navfn/NavfnROS on a Costmap2D."""

from pathlib import Path

from simplebot_navigation.kernel_cache import drop_stale_kernel_caches

drop_stale_kernel_caches(Path(__file__).parent, ("expansion_kernels", "path_kernels", "space_time_kernels"))


from simplebot_navigation.planning.config import GLOBAL_PLANNER, NAVFN, GlobalPlannerConfig, OrientationMode
from simplebot_navigation.planning.global_planner import (GlobalPlanner, PlanFailure, PlanResult, make_global_planner,
                                                          potential_to_occupancy, warm_up)
from simplebot_navigation.planning.expansion_kernels import POT_HIGH

__all__ = ["GLOBAL_PLANNER", "NAVFN", "POT_HIGH", "GlobalPlanner", "GlobalPlannerConfig",
           "OrientationMode", "PlanFailure", "PlanResult", "make_global_planner",
           "potential_to_occupancy", "warm_up"]
