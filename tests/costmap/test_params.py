"""Costmap parameters with ROS 1 semantics: defaults, rounding, plugins vs pre-Hydro (docs/reference.md §0.1, §2.7)."""

import numpy as np
import pytest

from simplebot_navigation.costmap.costmap_core import CostmapCore
from simplebot_navigation.costmap.inflation_layer import InflationLayer
from simplebot_navigation.costmap.obstacle_layer import ObstacleLayer
from simplebot_navigation.costmap.params import resolve_costmap_params
from simplebot_navigation.costmap.plugins import LAYERS

from simplebot_navigation.testing.lab_params import global_costmap_params, local_costmap_params


def test_lab_global_costmap():
    cfg = resolve_costmap_params(global_costmap_params(), "global_costmap")
    assert (cfg.global_frame, cfg.robot_base_frame, cfg.rolling_window) == ("odom", "base_link", False)
    assert (cfg.size_x, cfg.size_y, cfg.resolution, cfg.origin_x, cfg.origin_y) == (150, 150, 0.2, -15.0, -15.0)
    assert (cfg.update_frequency, cfg.publish_frequency, cfg.transform_tolerance) == (3.0, 1.0, 0.5)
    assert cfg.warnings[0] == 'global_costmap: Pre-Hydro parameter "static_map" unused since "plugins" is provided'
    assert cfg.warnings[1].startswith("global_costmap/obstacles/front_laser: inf_is_valid: +inf ranges clear")
    assert len(cfg.warnings) == 3
    obstacles, inflation = cfg.plugins
    assert (obstacles.name, obstacles.kind, inflation.name, inflation.kind) == \
        ("obstacles", "ObstacleLayer", "inflation_layer", "InflationLayer")
    assert inflation.params["inflation_radius"] == 1.5 and inflation.params["cost_scaling_factor"] == 8.0
    front, back = obstacles.params["sources"]
    assert (front.name, front.topic, front.sensor_frame, front.data_type) == \
        ("front_laser", "/front_laser/front_scan", "front_laser_link", "LaserScan")
    assert (back.obstacle_range, back.raytrace_range, back.inf_is_valid, back.clearing) == (15.0, 20.0, True, True)
    assert obstacles.params["track_unknown_space"] is True and cfg.track_unknown_space is False


def test_lab_local_costmap_is_built():
    cm = CostmapCore("local_costmap", local_costmap_params())
    assert cm.rolling_window and (cm.costmap.size_x, cm.costmap.resolution) == (100, 0.05)
    assert [type(p) for p in cm.plugins] == [ObstacleLayer, InflationLayer]
    assert [src.name for _, src in cm.observation_sources()] == ["front_laser", "back_laser"]
    assert cm.inscribed_radius == pytest.approx(0.33)
    np.testing.assert_allclose(cm.oriented_footprint(1.0, 0.0, 0.0)[0], [1.48, 0.33])
    assert cm.layer("obstacles").default_value == 255


def test_defaults_are_the_cfg_values():
    cfg = resolve_costmap_params({"plugins": []}, "c")
    assert (cfg.global_frame, cfg.update_frequency, cfg.publish_frequency, cfg.transform_tolerance) == \
        ("map", 5.0, 0.0, 0.3)
    assert (cfg.size_x, cfg.size_y, cfg.resolution, cfg.footprint_padding) == (200, 200, 0.05, 0.01)
    assert len(cfg.footprint) == 16 and cfg.robot_radius == 0.46


@pytest.mark.parametrize("width, cells", [(2.5, 60), (2.49, 40), (5, 100), (3.0, 60)])
def test_width_is_an_int_parameter_rounded_like_ros1(width, cells):
    cfg = resolve_costmap_params({"plugins": [], "width": width, "resolution": 0.05}, "c")
    assert cfg.size_x == cells


@pytest.mark.parametrize("key, value, message", [
    ("width", "abc", "c/width: expected an integer, got 'abc'"),
    ("origin_x", float("nan"), "c/origin_x: expected a number \\(finite\\), got nan"),
    ("rolling_window", "yes", "c/rolling_window: expected true or false"),
    ("resolution", 0.0, "c/resolution: must be > 0, got 0.0"),
    ("footprint", [[1, 2], [3, 4]], "c/footprint: a footprint needs at least three points"),
    ("plugins", "obstacles", "c/plugins: expected a list"),
])
def test_bad_values_name_the_key(key, value, message):
    with pytest.raises(ValueError, match=message):
        resolve_costmap_params({"plugins": [], key: value}, "c")


def test_unknown_plugin_type_names_plugin_and_type():
    with pytest.raises(ValueError, match="'obstacles' has unsupported type 'costmap_2d::VoxelLayer'"):
        resolve_costmap_params({"plugins": [{"name": "obstacles", "type": "costmap_2d::VoxelLayer"}]}, "c")
    assert LAYERS.kind("nav2_costmap_2d::InflationLayer", "x") == "InflationLayer"


def test_source_without_data_type_is_the_unsupported_pointcloud_default():
    params = {"plugins": [{"name": "obs", "type": "costmap_2d::ObstacleLayer"}],
              "obs": {"observation_sources": "cam", "cam": {"topic": "points"}}}
    with pytest.raises(ValueError, match=r"c/obs/cam/data_type: 'PointCloud' \(the default"):
        resolve_costmap_params(params, "c")


def test_plugins_given_parent_keys_are_copied_over_layer_keys():
    params = {
        "inflation_radius": 0.9, "obstacle_range": 4.0, "observation_sources": "scan", "map_type": "voxel",
        "plugins": [{"name": "obs", "type": "costmap_2d::ObstacleLayer"},
                    {"name": "infl", "type": "nav2_costmap_2d::InflationLayer"}],
        "infl": {"inflation_radius": 0.3},
        "obs": {"observation_sources": "laser", "obstacle_range": 1.0,
                "laser": {"data_type": "LaserScan"}},
    }
    cfg = resolve_costmap_params(params, "c")
    obs, infl = cfg.plugins
    assert infl.params["inflation_radius"] == 0.9                   # parent overwrites the layer's own value
    assert obs.params["sources"][0].obstacle_range == 4.0          # found by searchParam in the layer namespace
    assert obs.params["sources"][0].raytrace_range == 3.0
    assert 'c: Pre-Hydro parameter "map_type" unused since "plugins" is provided' in cfg.warnings
    assert any('"observation_sources" at the costmap level is not used' in w for w in cfg.warnings)


def test_plugins_given_top_level_sources_leave_the_layer_blind():
    params = {"observation_sources": "scan", "scan": {"data_type": "LaserScan"},
              "plugins": [{"name": "obstacles", "type": "costmap_2d::ObstacleLayer"}]}
    cfg = resolve_costmap_params(params, "c")
    assert cfg.plugins[0].params["sources"] == []
    assert "c/obstacles: no observation_sources, so this layer will never see an obstacle" in cfg.warnings


def test_pre_hydro_conversion():
    params = {"static_map": True, "map_topic": "/map2", "track_unknown_space": True, "obstacle_range": 3.5,
              "raytrace_range": 4.0, "max_obstacle_height": 0.6, "inflation_radius": 0.7,
              "cost_scaling_factor": 5.0, "observation_sources": "laser",
              "laser": {"data_type": "LaserScan", "clearing": True}}
    cm = CostmapCore("c", params)
    cfg = cm.config
    assert cfg.warnings == ['c: Parameter "plugins" not provided, loading pre-Hydro parameters']
    assert [(p.name, p.type) for p in cfg.plugins] == [("static_layer", "costmap_2d::StaticLayer"),
                                                       ("obstacle_layer", "costmap_2d::ObstacleLayer"),
                                                       ("inflation_layer", "costmap_2d::InflationLayer")]
    static, obstacle, inflation = (p.params for p in cfg.plugins)
    assert static["map_topic"] == "/map2" and static["track_unknown_space"] is True
    assert obstacle["max_obstacle_height"] == 0.6 and obstacle["track_unknown_space"] is True
    laser = obstacle["sources"][0]
    assert (laser.obstacle_range, laser.raytrace_range, laser.clearing, laser.marking) == (3.5, 4.0, True, True)
    assert (inflation["inflation_radius"], inflation["cost_scaling_factor"]) == (0.7, 5.0)
    assert cfg.track_unknown_space is True and cm.costmap.default_value == 255


def test_pre_hydro_without_static_map():
    cfg = resolve_costmap_params({"static_map": False}, "c")
    assert [p.name for p in cfg.plugins] == ["obstacle_layer", "inflation_layer"]


def test_footprint_and_robot_radius_are_searched_in_parent_namespaces():
    parents = [("/move_base", {"footprint": "[[0.2, 0.1], [0.2, -0.1], [-0.2, -0.1]]"})]
    cfg = resolve_costmap_params({"plugins": []}, "c", parents)
    assert cfg.footprint.tolist() == [[0.2, 0.1], [0.2, -0.1], [-0.2, -0.1]]
    cfg = resolve_costmap_params({"plugins": [], "footprint": "[]"}, "c", [("/move_base", {"robot_radius": 0.3})])
    assert cfg.robot_radius == 0.3 and np.allclose(np.hypot(*cfg.footprint.T), 0.3)


def test_source_lookup_errors():
    cm = CostmapCore("local_costmap", local_costmap_params())
    with pytest.raises(KeyError, match="'side_laser' is unknown"):
        cm.add_laser_scan("side_laser", [1.0], 0.0, 0.1, 0.1, 5.0, (0, 0, 0, 0), 0.0)
    cm.add_laser_scan("obstacles/front_laser", [1.0], 0.0, 0.1, 0.1, 5.0, (0, 0, 0, 0), 0.0)


def test_ros2_parameter_round_trip_gives_the_same_configuration():
    from simplebot_navigation.launch.rosparam import from_ros2_overrides, to_ros2_overrides

    tree = global_costmap_params()
    direct = resolve_costmap_params(tree, "global_costmap")
    via_ros2 = resolve_costmap_params(from_ros2_overrides(to_ros2_overrides(tree)), "global_costmap")
    assert via_ros2.footprint.tolist() == direct.footprint.tolist()
    assert via_ros2.plugins == direct.plugins and via_ros2.warnings == direct.warnings
