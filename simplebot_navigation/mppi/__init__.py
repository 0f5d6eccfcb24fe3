"""A sampling (MPPI) local planner with passive safety among moving obstacles (docs/reference.md §4.10): numpy,
with the rollouts and critics compiled by numba (mppi/kernels.py; warm_up() compiles or loads them ahead of the
first goal)."""

from pathlib import Path

from simplebot_navigation.kernel_cache import drop_stale_kernel_caches

drop_stale_kernel_caches(Path(__file__).parent, ("kernels",))

from simplebot_navigation.mppi.config import MppiConfig
from simplebot_navigation.mppi.controller import CycleResult, MppiController, warm_up

__all__ = ["CycleResult", "MppiConfig", "MppiController", "warm_up"]
