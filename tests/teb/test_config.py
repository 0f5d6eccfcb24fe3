import math

import pytest

from simplebot_navigation.teb.config import TebConfig

from .scenes import LAB_PARAMS


def test_defaults_are_the_dynamic_reconfigure_values():
    cfg = TebConfig()
    # cfg values where they differ from the C++ constructor (docs/reference.md §4.2)
    assert cfg.max_global_plan_lookahead_dist == 3.0
    assert cfg.global_plan_viapoint_sep == -0.1
    assert cfg.force_reinit_new_goal_angular == 0.78
    assert cfg.yaw_goal_tolerance == 0.1
    assert cfg.include_dynamic_obstacles is False
    assert cfg.obstacle_poses_affected == 30
    assert cfg.selection_obst_cost_scale == 2.0
    assert cfg.roadmap_graph_area_width == 5.0
    # and a few that are the same in both
    assert (cfg.dt_ref, cfg.dt_hysteresis, cfg.min_samples, cfg.max_samples) == (0.3, 0.1, 3, 500)
    assert (cfg.max_vel_x, cfg.max_vel_x_backwards, cfg.max_vel_theta) == (0.4, 0.2, 0.3)
    assert (cfg.acc_lim_x, cfg.acc_lim_theta) == (0.5, 0.5)
    assert (cfg.min_obstacle_dist, cfg.inflation_dist, cfg.penalty_epsilon) == (0.5, 0.6, 0.05)
    assert (cfg.no_inner_iterations, cfg.no_outer_iterations, cfg.weight_adapt_factor) == (5, 4, 2.0)
    assert cfg.enable_homotopy_class_planning is True
    assert cfg.max_number_classes == 5
    assert cfg.min_resolution_collision_check_angular == math.pi


def test_lab_yaml_frames_lose_the_leading_slash():
    cfg = TebConfig.from_params(LAB_PARAMS)
    assert cfg.map_frame == "odom"
    assert cfg.odom_topic == "/odom"
    assert cfg.footprint_model["type"] == "two_circles"
    assert cfg.warnings == []


@pytest.mark.parametrize("key, value", [
    ("max_vel_x", "fast"),
    ("enable_homotopy_class_planning", 1),
    ("min_samples", 3.5),
    ("max_vel_theta", True),
    ("map_frame", 5),
    ("footprint_model", ["two_circles"]),
])
def test_wrong_types_name_the_parameter(key, value):
    with pytest.raises(ValueError, match=key):
        TebConfig.from_params({key: value})


def test_integral_doubles_are_accepted_for_ints_and_ints_for_doubles():
    cfg = TebConfig.from_params({"min_samples": 4.0, "max_vel_x": 1})
    assert cfg.min_samples == 4 and isinstance(cfg.min_samples, int)
    assert cfg.max_vel_x == 1.0 and isinstance(cfg.max_vel_x, float)


def test_unknown_parameters_are_reported_not_fatal():
    cfg = TebConfig.from_params({"max_vel_z": 3.0})
    assert any("max_vel_z" in w for w in cfg.warnings)


def test_out_of_range_values_are_rejected():
    with pytest.raises(ValueError, match="dt_ref"):
        TebConfig.from_params({"dt_ref": 0.0})
    with pytest.raises(ValueError, match="max_samples"):
        TebConfig.from_params({"min_samples": 10, "max_samples": 5})
