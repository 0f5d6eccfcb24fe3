"""amcl's particle filter: weighting and the recovery averages, KLD resampling, random injection, selective
resampling, clusters and the estimate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplebot_navigation.localization import AmclParams, covariance_from_ros, covariance_to_ros
from simplebot_navigation.localization.clusters import cluster_labels, estimate
from simplebot_navigation.localization.map_grid import AmclMap
from simplebot_navigation.localization.particle_filter import ParticleFilter
from simplebot_navigation.testing.amcl_reference import kld_limit


def room() -> AmclMap:
    data = np.full((80, 100), -1, dtype=np.int8)
    data[10:70, 10:90] = 0
    data[40, 30:60] = 100
    return AmclMap(data, 0.1, (-2.0, 1.0, 0.0))


def make_filter(**overrides) -> ParticleFilter:
    return ParticleFilter(AmclParams(**overrides), room(), np.random.default_rng(0))


def test_weights_are_multiplied_normalised_and_feed_the_recovery_averages():
    pf = make_filter(max_particles=4, recovery_alpha_slow=0.1, recovery_alpha_fast=0.5)
    pf.init_uniform()
    pf.apply_weights(np.array([1.0, 2.0, 3.0, 4.0]))
    np.testing.assert_allclose(pf.weights, [0.1, 0.2, 0.3, 0.4])
    first = (1 + 2 + 3 + 4) / 4 / 4                   # the mean of weight x factor, weights 1/4 before
    assert pf.w_slow == pf.w_fast == pytest.approx(first)
    assert pf.n_effective == pytest.approx(1 / (0.01 + 0.04 + 0.09 + 0.16))
    pf.apply_weights(np.array([1.0, 1.0, 1.0, 1.0]))
    assert pf.w_slow == pytest.approx(first + 0.1 * (0.25 - first))
    assert pf.w_fast == pytest.approx(first + 0.5 * (0.25 - first))
    pf.apply_weights(np.zeros(4))
    np.testing.assert_allclose(pf.weights, 0.25)


def test_resampling_keeps_what_the_kld_bound_asks_for_the_bins_filled():
    pf = make_filter(min_particles=50, max_particles=3000)
    pf.init_gaussian((1.0, 4.0, 0.5), np.diag([0.15, 0.15, 0.08]) ** 2)
    pf.resample()
    bins = len(np.unique(np.floor(np.column_stack((pf.poses[:, 0] / 0.5, pf.poses[:, 1] / 0.5,
                                                   (pf.poses[:, 2] + math.pi) / math.radians(10)))), axis=0))
    limit = kld_limit(bins, 50, 3000, pf.params.kld_err, pf.params.kld_z)
    assert 50 < len(pf.poses) < 3000
    assert len(pf.poses) == limit + 1            # amcl's loop stops once it has more than the bound
    np.testing.assert_allclose(pf.weights, 1 / len(pf.poses))


def test_resampling_draws_heavy_particles_often_and_weightless_ones_never():
    pf = make_filter(min_particles=2000, max_particles=2000)
    pf.poses = np.array([[0.0, 2.0, 0.0], [3.0, 2.0, 0.0], [6.0, 2.0, 0.0], [3.0, 5.0, 1.0]])
    pf.weights = np.array([0.7, 0.2, 0.1, 0.0])
    pf.resample()
    drawn = [np.mean(np.all(pf.poses == pose, axis=1)) for pose in [[0.0, 2.0, 0.0], [3.0, 2.0, 0.0],
                                                                     [6.0, 2.0, 0.0], [3.0, 5.0, 1.0]]]
    np.testing.assert_allclose(drawn, [0.7, 0.2, 0.1, 0.0], atol=4 * math.sqrt(0.25 / 2000))


def test_when_the_short_term_likelihood_falls_random_free_poses_are_injected():
    pf = make_filter(min_particles=3000, max_particles=3000)
    pf.poses = np.tile([1.0, 4.0, 0.3], (3000, 1))
    pf.weights = np.full(3000, 1 / 3000)
    pf.w_slow, pf.w_fast = 1.0, 0.7
    assert pf.injection_probability() == pytest.approx(0.3)
    pf.resample()
    injected = ~np.all(pf.poses == [1.0, 4.0, 0.3], axis=1)
    assert injected.mean() == pytest.approx(0.3, abs=4 * math.sqrt(0.21 / 3000))
    cells = pf.map.to_grid(pf.poses[injected])
    assert pf.map.free[np.floor(cells[:, 1]).astype(int), np.floor(cells[:, 0]).astype(int)].all()
    assert pf.w_slow == pf.w_fast == 0.0           # restarted after an injection
    pf.w_slow, pf.w_fast = 1.0, 1.2
    assert pf.injection_probability() == 0.0


def test_selective_resampling_waits_for_the_effective_sample_size_to_drop():
    pf = make_filter(selective_resampling=True, max_particles=1000)
    pf.init_uniform()
    before = pf.poses.copy()
    pf.apply_weights(np.linspace(1.0, 1.5, 1000))           # nearly even: n_effective close to 1000
    pf.resample()
    np.testing.assert_array_equal(pf.poses, before)
    pf.apply_weights(np.where(np.arange(1000) < 100, 1.0, 1e-6))   # ~100 effective particles
    pf.resample()
    assert not np.array_equal(pf.poses, before)


def test_global_localization_spreads_max_particles_over_the_free_cells():
    pf = make_filter(max_particles=4000)
    pf.init_uniform()
    cells = pf.map.to_grid(pf.poses)
    rows, cols = np.floor(cells[:, 1]).astype(int), np.floor(cells[:, 0]).astype(int)
    assert len(pf.poses) == 4000 and pf.map.free[rows, cols].all()
    # uniform: each half of the room gets about half, and yaw covers the circle
    assert np.mean(cols < 50) == pytest.approx(0.5, abs=0.05)
    assert pf.poses[:, 2].min() < -3.0 and pf.poses[:, 2].max() > 3.0


def test_touching_bins_form_one_cluster_across_plus_minus_pi():
    rng = np.random.default_rng(1)
    west = np.column_stack((rng.normal(1.0, 0.05, 300), rng.normal(1.0, 0.05, 300),
                            np.angle(np.exp(1j * (math.pi + rng.normal(0, 0.05, 300))))))
    east = np.column_stack((rng.normal(6.0, 0.05, 100), rng.normal(1.0, 0.05, 100), rng.normal(0, 0.05, 100)))
    labels, count = cluster_labels(np.vstack((west, east)))
    assert count == 2 and len(set(labels[:300])) == 1 and len(set(labels[300:])) == 1
    result = estimate(np.vstack((west, east)), np.full(400, 1 / 400))
    assert result.clusters == 2 and result.weight == pytest.approx(0.75)
    assert (result.x, result.y) == (pytest.approx(west[:, 0].mean()), pytest.approx(west[:, 1].mean()))
    assert abs(math.remainder(result.yaw - math.pi, 2 * math.pi)) < 0.02


def test_the_estimate_is_the_heaviest_clusters_mean_with_the_whole_filters_covariance():
    rng = np.random.default_rng(2)
    a = np.column_stack((rng.normal(0.0, 0.1, 200), rng.normal(0.0, 0.2, 200), rng.normal(0.5, 0.1, 200)))
    b = np.column_stack((rng.normal(8.0, 0.1, 200), rng.normal(0.0, 0.1, 200), rng.normal(-1.0, 0.1, 200)))
    poses = np.vstack((a, b))
    weights = np.concatenate((np.full(200, 0.3 / 200), np.full(200, 0.7 / 200)))
    result = estimate(poses, weights)
    assert result.x == pytest.approx(b[:, 0].mean()) and result.y == pytest.approx(b[:, 1].mean())
    np.testing.assert_allclose(result.cluster_covariance[:2, :2], np.cov(b[:, :2].T, bias=True), rtol=1e-9)
    np.testing.assert_allclose(result.covariance[:2, :2], np.cov(poses[:, :2].T, aweights=weights, bias=True),
                               rtol=1e-9)
    resultant = abs(np.mean(np.exp(1j * b[:, 2])))
    assert result.cluster_covariance[2, 2] == pytest.approx(-2 * math.log(resultant))
    assert result.cluster_covariance[2, 2] == pytest.approx(np.var(b[:, 2]), rel=0.05)   # small spread: ~ var


def test_ros_covariance_holds_the_xy_block_and_the_yaw_variance():
    cov3 = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.02]])
    cov36 = covariance_to_ros(cov3)
    assert len(cov36) == 36
    assert (cov36[0], cov36[1], cov36[6], cov36[7], cov36[35]) == (0.04, 0.01, 0.01, 0.09, 0.02)
    assert sum(abs(v) for v in cov36) == pytest.approx(0.04 + 0.01 + 0.01 + 0.09 + 0.02)
    np.testing.assert_array_equal(covariance_from_ros(cov36), cov3)
