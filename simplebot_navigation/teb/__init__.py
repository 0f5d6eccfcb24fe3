"""Timed elastic band local planner (teb_local_planner): numpy, with the optimiser's hot path
compiled by numba (teb/*_kernels.py; warm_up() compiles or loads it ahead of the first goal)."""

from pathlib import Path

from simplebot_navigation.kernel_cache import SHARED_KERNELS, drop_stale_kernel_caches

drop_stale_kernel_caches(Path(__file__).parent,
                         ("footprint_kernels", "edge_kernels", "solver_kernels", "evasion_kernels"),
                         inlined=(SHARED_KERNELS,))

from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.optimizer import warm_up
from simplebot_navigation.teb.planner import TebLocalPlanner, VelocityCommandResult

__all__ = ["TebConfig", "FootprintModel", "TebLocalPlanner", "VelocityCommandResult", "warm_up"]
