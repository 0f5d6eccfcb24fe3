"""The lab's costmap parameter trees as rosparam builds them under /move_base (REFERENCE §2.7)."""

import copy

COMMON = {
    "footprint": [[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]],
    "footprint_padding": 0.03,
    "robot_base_frame": "base_link",
    "publish_frequency": 1.0,
    "transform_tolerance": 0.5,
    "inflation_layer": {"cost_scaling_factor": 8.0, "inflation_radius": 1.5},
    "obstacles": {
        "observation_sources": "front_laser back_laser",
        "track_unknown_space": True,
        "front_laser": {"data_type": "LaserScan", "sensor_frame": "/front_laser_link",
                        "topic": "/front_laser/front_scan", "marking": True, "clearing": True,
                        "expected_update_rate": 0.1, "inf_is_valid": True,
                        "obstacle_range": 15.0, "raytrace_range": 20.0},
        "back_laser": {"data_type": "LaserScan", "sensor_frame": "/back_laser_link",
                       "topic": "/back_laser/back_scan", "marking": True, "clearing": True,
                       "expected_update_rate": 0.1, "inf_is_valid": True,
                       "obstacle_range": 15.0, "raytrace_range": 20.0},
    },
}

GLOBAL = {
    "static_map": True, "rolling_window": False, "global_frame": "/odom", "update_frequency": 3.0,
    "width": 30.0, "height": 30.0, "resolution": 0.2, "origin_x": -15.0, "origin_y": -15.0,
    "plugins": [{"name": "obstacles", "type": "costmap_2d::ObstacleLayer"},
                {"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}],
}

LOCAL = {
    "global_frame": "/odom",
    "plugins": [{"name": "obstacles", "type": "costmap_2d::ObstacleLayer"},
                {"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}],
    "static_map": False, "rolling_window": True, "update_frequency": 10,
    "width": 5.0, "height": 5.0, "resolution": 0.05, "origin_x": 0.0, "origin_y": 0.0,
}


def _merge(base: dict, extra: dict) -> dict:
    """rosparam load: later files merge into existing namespaces."""
    out = copy.deepcopy(base)
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def global_costmap_params() -> dict:
    return _merge(COMMON, GLOBAL)


def local_costmap_params() -> dict:
    return _merge(COMMON, LOCAL)
