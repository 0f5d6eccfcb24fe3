"""GlobalPlanner / NavfnROS parameters: ROS defaults and validation (docs/reference.md §3.1, §3.3)."""

import pytest

from simplebot_navigation.planning import GlobalPlannerConfig, OrientationMode


def test_defaults_are_the_ros_defaults():
    cfg = GlobalPlannerConfig.from_params({})
    assert (cfg.use_dijkstra, cfg.use_quadratic, cfg.use_grid_path, cfg.allow_unknown) == (
        True, True, False, True)
    assert (cfg.lethal_cost, cfg.neutral_cost, cfg.cost_factor) == (253, 50, 3.0)
    assert cfg.orientation_mode is OrientationMode.FORWARD and cfg.orientation_window_size == 1
    assert (cfg.outline_map, cfg.publish_potential, cfg.publish_scale) == (True, True, 100)
    assert (cfg.default_tolerance, cfg.old_navfn_behavior, cfg.navfn) == (0.0, False, False)


def test_lab_global_planner_yaml():
    cfg = GlobalPlannerConfig.from_params({"publish_potential": False})
    assert cfg.publish_potential is False and cfg.use_dijkstra


def test_values_are_converted():
    cfg = GlobalPlannerConfig.from_params({"orientation_mode": 3, "lethal_cost": 250.0,
                                           "cost_factor": 2, "default_tolerance": 1})
    assert cfg.orientation_mode is OrientationMode.FORWARD_THEN_INTERPOLATE
    assert cfg.lethal_cost == 250 and isinstance(cfg.lethal_cost, int)
    assert cfg.cost_factor == 2.0 and cfg.default_tolerance == 1.0


@pytest.mark.parametrize("params, name", [
    ({"use_dijkstra": "false"}, "use_dijkstra"),
    ({"allow_unknown": 1}, "allow_unknown"),
    ({"lethal_cost": 256}, "lethal_cost"),
    ({"lethal_cost": 252.5}, "lethal_cost"),
    ({"neutral_cost": 0}, "neutral_cost"),
    ({"cost_factor": 0.0}, "cost_factor"),
    ({"cost_factor": True}, "cost_factor"),
    ({"orientation_mode": 7}, "orientation_mode"),
    ({"orientation_window_size": 0}, "orientation_window_size"),
    ({"default_tolerance": -0.5}, "default_tolerance"),
    ({"default_tolerance": float("inf")}, "default_tolerance"),
    ({"publish_scale": 200}, "publish_scale"),
    ({"cost_factor": float("nan")}, "cost_factor"),
])
def test_bad_parameters_name_the_parameter(params, name):
    with pytest.raises(ValueError, match=name):
        GlobalPlannerConfig.from_params(params)


def test_navfn_parameters():
    cfg = GlobalPlannerConfig.from_navfn_params({"allow_unknown": False, "default_tolerance": 0.5,
                                                 "visualize_potential": True})
    assert cfg.navfn and not cfg.allow_unknown and cfg.default_tolerance == 0.5
    assert cfg.publish_potential and cfg.orientation_mode is OrientationMode.NONE
    assert GlobalPlannerConfig.from_navfn_params({}).publish_potential is False
    # navfn has no orientation filter: the key is ignored, as ROS 1 would, and named once
    cfg = GlobalPlannerConfig.from_navfn_params({"orientation_mode": 1})
    assert cfg.orientation_mode is OrientationMode.NONE
    assert cfg.warnings == ("NavfnROS: unknown parameter 'orientation_mode' ignored",)


def test_a_misspelt_key_is_ignored_with_a_warning_naming_the_closest_key():
    cfg = GlobalPlannerConfig.from_params({"use_dijstra": False})
    assert cfg.use_dijkstra is True
    assert cfg.warnings == ("GlobalPlanner: unknown parameter 'use_dijstra' ignored (did you mean 'use_dijkstra'?)",)
