"""Moving obstacles from planar lidar scans: segmentation, a Kalman tracker per obstacle, and where the costmaps
should clear after them (docs/reference.md §6). No rclpy."""

from pathlib import Path

from simplebot_navigation.kernel_cache import drop_stale_kernel_caches

drop_stale_kernel_caches(Path(__file__).parent, ("tracking_kernels",))

from simplebot_navigation.perception.params import TrackerParams
from simplebot_navigation.perception.segmentation import Clusters, Scan, segment
from simplebot_navigation.perception.structure import StaticCells
from simplebot_navigation.perception.tracker import ObstacleTracker, Track

__all__ = ["Clusters", "ObstacleTracker", "Scan", "StaticCells", "Track", "TrackerParams", "segment"]
