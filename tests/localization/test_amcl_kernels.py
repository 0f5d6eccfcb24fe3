"""amcl's compiled kernels against the plain numpy / Python references (testing/amcl_reference.py) on random input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplebot_navigation.localization import amcl_kernels as kernels
from simplebot_navigation.localization.clusters import BIN_XY, BIN_YAW, YAW_BINS
from simplebot_navigation.localization.map_grid import AmclMap
from simplebot_navigation.testing import amcl_reference as reference


def random_map(rng, height=60, width=80, blocked_share=0.08) -> np.ndarray:
    """Walls round the edge (with a gap, so rays can leave the map), random blocks and a few unknown cells."""
    data = np.zeros((height, width), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    data[-1, 20:30] = 0
    data[rng.random((height, width)) < blocked_share] = 100
    data[rng.random((height, width)) < 0.01] = -1
    return data


def random_grid_poses(rng, n, height, width) -> np.ndarray:
    """Poses in cell units, some beyond the map."""
    return np.column_stack((rng.uniform(-5, width + 5, n), rng.uniform(-5, height + 5, n), rng.uniform(-4, 4, n)))


def test_likelihood_field_weights_match_the_reference():
    rng = np.random.default_rng(1)
    table = rng.uniform(0.01, 1.0, (50, 70))
    poses = random_grid_poses(rng, 300, 50, 70)
    ends = rng.uniform(-40, 40, (45, 2))
    out = np.empty(len(poses))
    kernels.likelihood_field_weights(poses, ends, table, 0.123, out)
    np.testing.assert_allclose(out, reference.likelihood_field_weights(poses, ends, table, 0.123), rtol=1e-12)


@pytest.mark.parametrize("beamskip, skip_threshold, error_threshold", [
    (False, 0.3, 0.9), (True, 0.3, 0.9), (True, 0.3, 0.0), (True, 0.9, 1.0)])
def test_likelihood_field_prob_weights_match_the_reference(beamskip, skip_threshold, error_threshold):
    rng = np.random.default_rng(2)
    table = rng.uniform(0.2, 1.0, (50, 70))
    near = rng.random((50, 70)) < 0.5
    poses = np.column_stack((rng.normal(35, 3, 200), rng.normal(25, 3, 200), rng.normal(0, 0.3, 200)))
    ends = rng.uniform(-30, 30, (40, 2))
    out = np.empty(len(poses))
    used = kernels.likelihood_field_prob_weights(poses, ends, np.log(table), math.log(0.3), near, beamskip, 50,
                                                 skip_threshold, error_threshold, out)
    expected = reference.likelihood_field_prob_weights(poses, ends, table, 0.3, near, beamskip, 50, skip_threshold,
                                                       error_threshold)
    np.testing.assert_allclose(out, expected, rtol=1e-9)
    if not beamskip or error_threshold == 0.0:
        assert used == len(ends)


def test_beam_skipping_drops_the_beams_most_particles_find_off_the_map():
    rng = np.random.default_rng(3)
    table = np.full((50, 70), 0.5)
    near = np.zeros((50, 70), dtype=bool)
    near[:, :35] = True                   # beam ends in the left half agree with the map
    poses = np.column_stack((rng.normal(35, 0.5, 100), rng.normal(25, 0.5, 100), np.zeros(100)))
    ends = np.array([[-10.0, 0.0], [-12.0, 1.0], [10.0, 0.0], [12.0, -1.0]])
    out = np.empty(len(poses))
    used = kernels.likelihood_field_prob_weights(poses, ends, np.log(table), math.log(0.5), near, True, 4, 0.3,
                                                 0.9, out)
    assert used == 2
    np.testing.assert_allclose(out, 0.25)


def test_cast_range_lands_on_the_cells_of_the_step_by_step_walk():
    rng = np.random.default_rng(4)
    amap = AmclMap(random_map(rng), 0.05)
    blocked, clearance = amap.blocked(), amap.clearance()
    for _ in range(3000):
        ox, oy = rng.uniform(-3, 83), rng.uniform(-3, 63)
        angle, cells = rng.uniform(-4, 4), rng.choice([0.3, 2.0, 20.0, 60.0, 150.0])
        expected = reference.cast_range(ox, oy, angle, cells, blocked)
        assert kernels.cast_range(ox, oy, angle, cells, blocked, clearance) == expected, (ox, oy, angle, cells)


def test_cast_range_in_open_space_jumps_to_the_same_end():
    blocked = np.zeros((200, 300), dtype=np.uint8)
    blocked[:, 250] = 1
    amap_clearance = AmclMap(np.where(blocked, 100, 0).astype(np.int8), 0.05).clearance()
    for angle in np.linspace(-0.7, 0.7, 41):
        expected = reference.cast_range(20.5, 100.3, angle, 400.0, blocked)
        assert kernels.cast_range(20.5, 100.3, angle, 400.0, blocked, amap_clearance) == expected


def test_beam_model_weights_match_the_reference():
    rng = np.random.default_rng(5)
    amap = AmclMap(random_map(rng, blocked_share=0.03), 0.05)
    poses = np.column_stack((rng.uniform(5, 75, 40), rng.uniform(5, 55, 40), rng.uniform(-3.1, 3.1, 40)))
    sensor = np.array([7.0, 0.0, 0.1])
    bearings = np.linspace(-2.0, 2.0, 25)
    range_max = 2.5
    ranges = rng.uniform(0.1, range_max, 25)
    ranges[[3, 9]] = range_max
    z = np.array([0.8, 0.1, 0.05, 0.05, 0.2, 0.1])
    out = np.empty(len(poses))
    kernels.beam_model_weights(poses, sensor, bearings, ranges, range_max, 0.05, amap.blocked(), amap.clearance(),
                               z, out)
    expected = reference.beam_model_weights(poses, sensor, bearings, ranges, range_max, 0.05, amap.blocked(), z)
    np.testing.assert_allclose(out, expected, rtol=1e-12)


@pytest.mark.parametrize("spread, w_diff", [(0.05, 0.0), (0.4, 0.0), (3.0, 0.0), (0.2, 0.3)])
def test_kld_resample_matches_the_reference(spread, w_diff):
    rng = np.random.default_rng(6)
    n, min_n, max_n = 3000, 100, 2500
    poses = np.column_stack((rng.normal(2.0, spread, n), rng.normal(-1.0, spread, n),
                             rng.uniform(-math.pi, math.pi, n) * min(spread, 1.0)))
    weights = rng.random(n) ** 3
    weights[::7] = 0.0
    cumulative = np.concatenate(([0.0], np.cumsum(weights)))
    u_pick, u_inject = rng.random(max_n), rng.random(max_n)
    random_poses = np.column_stack((rng.uniform(-10, 10, max_n), rng.uniform(-10, 10, max_n),
                                    rng.uniform(-math.pi, math.pi, max_n)))
    out = np.empty((max_n, 3))
    count = kernels.kld_resample(poses, cumulative, u_pick, u_inject, random_poses, w_diff, BIN_XY, BIN_YAW,
                                 YAW_BINS, min_n, max_n, 0.01, 0.99, out)
    expected = reference.kld_resample(poses, cumulative, u_pick, u_inject, random_poses, w_diff, min_n, max_n, 0.01,
                                      0.99)
    assert count == len(expected)
    np.testing.assert_array_equal(out[:count], expected)
    drawn = np.isin(out[:count, 0], poses[:, 0])
    assert not np.isin(out[:count][drawn, 0], poses[weights == 0, 0]).any(), "a zero-weight particle was drawn"


def test_kld_limit_follows_fox():
    for k in range(0, 400):
        assert kernels.kld_limit(k, 100, 5000, 0.01, 0.99) == reference.kld_limit(k, 100, 5000, 0.01, 0.99)
    b = 2 / (9 * 49)
    assert kernels.kld_limit(50, 1, 100000, 0.05, 2.0) == math.ceil(49 / 0.1 * (1 - b + math.sqrt(b) * 2.0) ** 3)
    assert kernels.kld_limit(1, 100, 5000, 0.01, 0.99) == 5000        # amcl: one bin asks for max_particles
