"""Moving obstacles in the TEB optimiser: the edges, their prediction and the selection cost."""

import numpy as np
import pytest

from simplebot_navigation.teb import edge_kernels
from simplebot_navigation.teb.band import TimedElasticBand
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.optimizer import TebOptimizer

from .scenes import LAB_TWO_CIRCLES, straight_plan


def straight_band(cfg, length=3.0):
    band = TimedElasticBand()
    band.init_from_path(straight_plan(0.0, length)[::6], cfg.max_vel_x, cfg.max_vel_theta, True, cfg.min_samples,
                        False)
    return band


@pytest.mark.parametrize("predict", [True, False])
def test_each_interior_pose_meets_the_obstacle_where_it_is_predicted_at_the_pose_time(predict):
    cfg = TebConfig.from_params({"include_dynamic_obstacles": predict})
    band = straight_band(cfg)
    crossing = np.array([[1.5, -1.0, 0.0, 0.3, 0.25]])         # crosses the band's line upwards
    edges = TebOptimizer(cfg, FootprintModel.point()).build_edges(band, None, None, 50.0, crossing, 400.0)
    stamps = band.time_stamps
    np.testing.assert_array_equal(edges.dyn_pose, np.arange(1, len(band.poses) - 1))
    expected_y = -1.0 + 0.3 * stamps[1:-1] if predict else np.full(len(stamps) - 2, -1.0)
    np.testing.assert_allclose(edges.dyn_obstacle, np.column_stack([np.full_like(expected_y, 1.5), expected_y,
                                                                    np.full_like(expected_y, 0.25)]))
    assert edges.dynamic_weight == 400.0


def test_pairs_beyond_the_association_cutoff_get_no_edge():
    cfg = TebConfig.from_params({"min_obstacle_dist": 0.3, "obstacle_association_cutoff_factor": 2.0})
    band = straight_band(cfg, length=6.0)
    model = FootprintModel.from_params(LAB_TWO_CIRCLES)
    obstacles = np.array([[5.5, 0.5, 0.0, 0.0, 0.2],           # near the end of the band only
                          [1.0, 3.0, 0.0, 0.0, 0.2]])          # 3 m off the band: beyond 0.6 + 0.4 + 0.2
    edges = TebOptimizer(cfg, model).build_edges(band, None, None, 50.0, obstacles, 50.0)
    near = band.poses[edges.dyn_pose]
    assert len(edges.dyn_pose) and np.all(edges.dyn_obstacle[:, 1] == 0.5)
    reach = 0.3 * 2.0 + model.bounding_radius + 0.2
    assert np.all(np.hypot(near[:, 0] - 5.5, near[:, 1] - 0.5) <= reach)
    inner = band.poses[1:-1]
    assert np.count_nonzero(np.hypot(inner[:, 0] - 5.5, inner[:, 1] - 0.5) <= reach) == len(edges.dyn_pose)


def test_dynamic_obstacle_cost_counts_in_the_selection_like_static_obstacles():
    cfg = TebConfig.from_params({"selection_obst_cost_scale": 7.0})
    band = straight_band(cfg)
    opt = TebOptimizer(cfg, FootprintModel.circular(0.3))
    edges = opt.build_edges(band, None, None, 50.0, np.array([[1.5, 0.2, 0.0, 0.0, 0.3]]), 50.0)
    params = opt.parameters(edges)
    chi2 = edge_kernels.family_chi2(band.poses, band.time_diffs, params, edges.arrays, opt.model.kernel_model,
                                    opt.residual_count(edges, params))
    assert chi2[edge_kernels.F_DYNAMIC] > 0
    others = chi2.sum() - chi2[edge_kernels.F_DYNAMIC]
    assert opt.selection_cost(band, edges) == pytest.approx(others + 7.0 * chi2[edge_kernels.F_DYNAMIC])


def test_the_band_gives_way_to_the_obstacle_where_it_will_be_not_where_it_is():
    cfg = TebConfig.from_params({"include_dynamic_obstacles": True, "max_vel_x": 0.5})
    model = FootprintModel.circular(0.25)
    # a 0.4 m obstacle comes head-on at 0.5 m/s, 0.3 m left of the band's line; now it is 6 m
    # away, beyond the band's end, but the band meets it half-way
    head_on = np.array([[6.0, 0.3, -0.5, 0.0, 0.4]])
    band = straight_band(cfg, length=4.0)
    TebOptimizer(cfg, model).optimize(band, np.zeros((0, 2)), None, (0.5, 0.0), False, dynamic_obstacles=head_on)
    centres = head_on[0, :2] + band.time_stamps[:, None] * head_on[0, 2:4]
    clearance = np.hypot(*(band.poses[:, :2] - centres).T) - 0.25 - 0.4
    assert clearance[1:-1].min() > cfg.min_obstacle_dist - 0.1
    assert band.poses[:, 1].min() < -0.6                         # it swerved right
    assert np.hypot(*np.diff(band.poses[:, :2], axis=0).T).max() < 0.3
