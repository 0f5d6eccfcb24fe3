"""amcl's parameters: every ROS 1 parameter is declared, checked, and says whether it does anything here."""

from __future__ import annotations

import math

import pytest

from simplebot_navigation.localization import Amcl, AmclParams
from simplebot_navigation.parameters import ParameterError, Status, fields_of

#: every parameter ROS 1 noetic's amcl reads (amcl_node.cpp and cfg/AMCL.cfg; restore_defaults is only a
#: dynamic_reconfigure button)
ROS1_PARAMETERS = """
min_particles max_particles kld_err kld_z update_min_d update_min_a resample_interval transform_tolerance
recovery_alpha_slow recovery_alpha_fast selective_resampling initial_pose_x initial_pose_y initial_pose_a
initial_cov_xx initial_cov_yy initial_cov_aa gui_publish_rate save_pose_rate use_map_topic first_map_only
tf_broadcast force_update_after_initialpose force_update_after_set_map std_warn_level_x std_warn_level_y
std_warn_level_yaw bag_scan_period laser_min_range laser_max_range laser_max_beams laser_z_hit laser_z_short
laser_z_max laser_z_rand laser_sigma_hit laser_lambda_short laser_likelihood_max_dist laser_model_type do_beamskip
beam_skip_distance beam_skip_threshold beam_skip_error_threshold odom_model_type odom_alpha1 odom_alpha2
odom_alpha3 odom_alpha4 odom_alpha5 odom_frame_id base_frame_id global_frame_id""".split()


def test_every_ros1_parameter_is_declared_and_described():
    specs = fields_of(AmclParams)
    assert sorted(set(ROS1_PARAMETERS) - set(specs)) == []
    assert sorted(set(specs) - set(ROS1_PARAMETERS)) == ["global_localization_candidates",      # ours
                                                        "global_localization_uniform_share",
                                                        "recovery_match_interval", "seed"]
    for name, spec in specs.items():
        assert spec.doc, name
        assert spec.implemented or spec.reason, name


def test_the_defaults_are_what_the_ros1_node_falls_back_to():
    p = AmclParams.from_params({})
    assert (p.min_particles, p.max_particles, p.kld_err, p.kld_z) == (100, 5000, 0.01, 0.99)
    assert (p.update_min_d, p.update_min_a, p.resample_interval) == (0.2, math.pi / 6, 2)
    assert (p.recovery_alpha_slow, p.recovery_alpha_fast) == (0.001, 0.1)
    assert (p.initial_cov_xx, p.initial_cov_yy, p.initial_cov_aa) == (0.25, 0.25, (math.pi / 12) ** 2)
    assert (p.laser_z_hit, p.laser_z_short, p.laser_z_max, p.laser_z_rand) == (0.95, 0.1, 0.05, 0.05)
    assert (p.laser_sigma_hit, p.laser_lambda_short, p.laser_likelihood_max_dist) == (0.2, 0.1, 2.0)
    assert (p.laser_max_beams, p.laser_model_type, p.odom_model_type) == (30, "likelihood_field", "diff")
    assert (p.beam_skip_distance, p.beam_skip_threshold, p.beam_skip_error_threshold) == (0.5, 0.3, 0.9)
    assert (p.odom_frame_id, p.base_frame_id, p.global_frame_id) == ("odom", "base_link", "map")
    assert p.warnings == []


@pytest.mark.parametrize("given, message", [
    ({"kld_err": 0.0}, "amcl/kld_err: must be"), ({"resample_interval": 0}, "amcl/resample_interval"),
    ({"min_particles": "many"}, "amcl/min_particles: expected an integer"),
    ({"laser_sigma_hit": math.nan}, "amcl/laser_sigma_hit"), ({"initial_cov_aa": 0.0}, "amcl/initial_cov_aa"),
    ({"laser_model_type": "likelihood"}, "amcl/laser_model_type: must be one of"),
    ({"odom_model_type": "ackermann"}, "amcl/odom_model_type: must be one of"),
    ({"min_particles": 600, "max_particles": 500}, "amcl/min_particles: must not exceed max_particles")])
def test_bad_values_are_refused_naming_the_parameter(given, message):
    with pytest.raises(ParameterError, match=message):
        AmclParams.from_params(given)


def test_what_has_no_effect_here_says_so():
    p = AmclParams.from_params({"odom_model_type": "omni-corrected", "odom_alpha5": 0.1, "std_warn_level_x": 0.5,
                                "gui_publish_rate": 10.0, "laser_max_beam": 60, "transform_tolerance": 0.5})
    assert p.motion_model == "diff-corrected"
    text = "\n".join(p.warnings)
    assert "amcl/odom_model_type has no effect: this robot is a differential drive" in text
    assert "amcl/odom_alpha5 has no effect: this robot is a differential drive" in text
    assert "amcl/std_warn_level_x is accepted but not implemented" in text
    assert "transform_tolerance" not in text          # the node's: it post-dates map -> odom
    assert "amcl/gui_publish_rate is accepted but not implemented" in text
    assert "unknown parameter 'laser_max_beam' ignored (did you mean 'laser_max_beams'?)" in text
    assert fields_of(AmclParams)["odom_alpha5"].status is Status.NOT_FOR_THIS_ROBOT
    assert not fields_of(AmclParams)["laser_model_type"].dynamic


def test_the_misspelt_beam_skip_error_threshold_wins_as_in_amcl():
    p = AmclParams.from_params({"beam_skip_error_threshold_": 0.4, "beam_skip_error_threshold": 0.8})
    assert p.beam_skip_error_threshold == 0.4


@pytest.mark.parametrize("params, message", [
    (AmclParams(laser_model_type="beam_model"), "amcl/laser_model_type"), (AmclParams(kld_err=0.0), "amcl/kld_err"),
    (AmclParams(max_particles=0), "amcl/max_particles"), (AmclParams(do_beamskip=1), "amcl/do_beamskip")])
def test_amcl_checks_a_configuration_built_by_hand(params, message):
    with pytest.raises(ParameterError, match=message):
        Amcl(params, [[0, 0], [0, 0]], 0.05)
