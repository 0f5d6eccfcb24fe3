import dataclasses
import math

import pytest

from simplebot_navigation.parameters import fields_of
from simplebot_navigation.teb.config import TebConfig

from .scenes import LAB_PARAMS


def test_defaults_are_the_dynamic_reconfigure_values():
    cfg = TebConfig()
    # cfg values where they differ from the C++ constructor (docs/reference.md §4.2)
    assert cfg.trajectory.max_global_plan_lookahead_dist == 3.0
    assert cfg.trajectory.global_plan_viapoint_sep == -0.1
    assert cfg.trajectory.force_reinit_new_goal_angular == 0.78
    assert cfg.goal_tolerance.yaw_goal_tolerance == 0.1
    assert cfg.obstacles.include_dynamic_obstacles is False
    assert cfg.obstacles.obstacle_poses_affected == 30
    assert cfg.hcp.selection_obst_cost_scale == 2.0
    assert cfg.hcp.roadmap_graph_area_width == 5.0
    # and a few that are the same in both
    trajectory, robot, optim = cfg.trajectory, cfg.robot, cfg.optim
    assert (trajectory.dt_ref, trajectory.dt_hysteresis) == (0.3, 0.1)
    assert (trajectory.min_samples, trajectory.max_samples) == (3, 500)
    assert (robot.max_vel_x, robot.max_vel_x_backwards, robot.max_vel_theta) == (0.4, 0.2, 0.3)
    assert (robot.acc_lim_x, robot.acc_lim_theta) == (0.5, 0.5)
    assert (cfg.obstacles.min_obstacle_dist, cfg.obstacles.inflation_dist, optim.penalty_epsilon) == (0.5, 0.6, 0.05)
    assert (optim.no_inner_iterations, optim.no_outer_iterations, optim.weight_adapt_factor) == (5, 4, 2.0)
    assert cfg.hcp.enable_homotopy_class_planning is True
    assert cfg.hcp.max_number_classes == 5
    assert cfg.trajectory.min_resolution_collision_check_angular == math.pi


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
    assert cfg.trajectory.min_samples == 4 and isinstance(cfg.trajectory.min_samples, int)
    assert cfg.robot.max_vel_x == 1.0 and isinstance(cfg.robot.max_vel_x, float)


def test_unknown_parameters_are_reported_not_fatal():
    cfg = TebConfig.from_params({"max_vel_z": 3.0})
    assert any("max_vel_z" in w for w in cfg.warnings)


def test_out_of_range_values_are_rejected():
    with pytest.raises(ValueError, match="dt_ref"):
        TebConfig.from_params({"dt_ref": 0.0})
    with pytest.raises(ValueError, match="max_samples"):
        TebConfig.from_params({"min_samples": 10, "max_samples": 5})


@pytest.mark.parametrize("section, names", [
    ("trajectory", ["dt_ref", "max_samples", "feasibility_check_no_poses", "control_look_ahead_poses"]),
    ("robot", ["max_vel_x", "acc_lim_theta", "use_proportional_saturation", "transform_tolerance"]),
    ("goal_tolerance", ["xy_goal_tolerance", "free_goal_vel", "trans_stopped_vel", "complete_global_plan"]),
    ("obstacles", ["min_obstacle_dist", "include_dynamic_obstacles", "costmap_converter_plugin"]),
    ("optim", ["no_inner_iterations", "weight_obstacle", "weight_dynamic_obstacle", "obstacle_cost_exponent"]),
    ("moving_obstacles", ["dynamic_obstacle_prediction_horizon", "dynamic_obstacle_evasion_horizon"]),
    ("hcp", ["enable_homotopy_class_planning", "selection_obst_cost_scale", "roadmap_graph_area_width"]),
    ("recovery", ["shrink_horizon_backup", "oscillation_filter_duration", "divergence_detection_enable"]),
])
def test_parameters_sit_in_the_sections_of_teb_config_h(section, names):
    given = {name: fields_of(TebConfig)[name].default for name in names}
    assert {name: getattr(getattr(TebConfig.from_params(given), section), name) for name in names} == given


def test_only_the_frames_and_the_footprint_model_are_outside_a_section():
    top = [f.name for f in dataclasses.fields(TebConfig) if f.name in fields_of(TebConfig)]
    assert top == ["odom_topic", "map_frame", "footprint_model"]
    assert len(fields_of(TebConfig)) == 122
