"""Occupancy maps as map_server reads and map_saver writes them (no rclpy)."""

from simplebot_navigation.maps.images import MAX_CELLS, MAX_SIDE, MapError
from simplebot_navigation.maps.map_io import OccupancyMap, load_map, save_map

__all__ = ["MAX_CELLS", "MAX_SIDE", "MapError", "OccupancyMap", "load_map", "save_map"]
