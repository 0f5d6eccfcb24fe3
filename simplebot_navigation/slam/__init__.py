"""SLAM without ROS: a correlative scan matcher, a pose graph, a log-odds occupancy grid, the mapper that ties
them together, and frontiers for exploration (docs/reference.md §13)."""

from pathlib import Path

from simplebot_navigation.kernel_cache import drop_stale_kernel_caches

drop_stale_kernel_caches(Path(__file__).parent, ("matcher_kernels", "occupancy_kernels"))
