"""What stops the robot whatever the planner does: the collision monitor's judgement (no rclpy)."""

from pathlib import Path

from simplebot_navigation.kernel_cache import SHARED_KERNELS, drop_stale_kernel_caches

drop_stale_kernel_caches(Path(__file__).parent, ("collision_kernels",), inlined=(SHARED_KERNELS,))
