"""amcl's laser models: the likelihood field, which beams count and how ranges are read, and each model's weight
for hand-placed beams."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplebot_navigation.localization import Amcl, AmclParams, RangeScan
from simplebot_navigation.localization.laser_models import LaserModel, beam_indices, read_beams
from simplebot_navigation.localization.map_grid import AmclMap
from simplebot_navigation.testing import amcl_reference as reference

RES = 0.05
WALL_COL = 60                     # occupied column: x in [3.0, 3.05), centre 3.025
ROBOT = np.array([[1.0, 1.5, 0.0]])
SENSOR = (0.21, 0.0, 0.0)         # so the sensor sits at (1.21, 1.5), in column 24


def wall_map() -> np.ndarray:
    data = np.zeros((60, 100), dtype=np.int8)
    data[:, WALL_COL] = 100
    return data


def scan(ranges, angle_min=0.0, increment=math.pi / 2, range_min=0.1, range_max=4.0) -> RangeScan:
    return RangeScan(np.array(ranges, dtype=float), angle_min, increment, range_min, range_max, SENSOR)


def weight(params: AmclParams, one_scan: RangeScan, data=None, origin=(0.0, 0.0, 0.0), robot=ROBOT) -> float:
    model = LaserModel(params, AmclMap(wall_map() if data is None else data, RES, origin))
    return float(model.weights(model.map.to_grid(robot), one_scan)[0])


def gauss(params: AmclParams, d: float) -> float:
    return params.laser_z_hit * math.exp(-d * d / (2 * params.laser_sigma_hit ** 2))


def test_the_likelihood_field_is_the_capped_distance_to_the_nearest_occupied_cell():
    rng = np.random.default_rng(0)
    data = np.where(rng.random((30, 40)) < 0.03, 100, 0).astype(np.int8)
    data[rng.random((30, 40)) < 0.05] = -1
    amap = AmclMap(data, 0.1)
    np.testing.assert_allclose(amap.obstacle_distance(0.7), reference.obstacle_distance(data == 100, 0.1, 0.7))


def test_likelihood_field_sums_the_cubes_of_the_beams_and_skips_max_range_and_nan():
    params = AmclParams(laser_max_beams=30)
    # beam 0 along +x ends at x = 2.92 (column 58, 0.1 m from the wall's column); beam 1 along +y ends in column 24,
    # 1.8 m from the wall; beam 2 is a max-range reading, beam 3 NaN
    ranges = [1.71, 1.0, 4.0, math.nan]
    pz = [gauss(params, 0.1) + params.laser_z_rand / 4.0, gauss(params, 1.8) + params.laser_z_rand / 4.0]
    assert weight(params, scan(ranges)) == pytest.approx(1 + pz[0] ** 3 + pz[1] ** 3, rel=1e-12)
    capped = AmclParams(laser_max_beams=30, laser_likelihood_max_dist=1.0)
    pz[1] = gauss(capped, 1.0) + capped.laser_z_rand / 4.0
    assert weight(capped, scan(ranges)) == pytest.approx(1 + pz[0] ** 3 + pz[1] ** 3, rel=1e-12)


def test_likelihood_field_prob_multiplies_the_beams():
    params = AmclParams(laser_max_beams=30, laser_model_type="likelihood_field_prob")
    pz = [gauss(params, 0.1) + params.laser_z_rand / 4.0, gauss(params, 1.8) + params.laser_z_rand / 4.0]
    assert weight(params, scan([1.71, 1.0, 4.0])) == pytest.approx(pz[0] * pz[1], rel=1e-12)


def test_beam_ends_beyond_the_map_count_as_far_from_everything():
    params = AmclParams(laser_max_beams=30)
    off_map = gauss(params, params.laser_likelihood_max_dist) + params.laser_z_rand / 4.0
    # along -x from x = 1.21: the end at x = -0.29 lies beyond the map's left edge
    assert weight(params, scan([1.5], angle_min=math.pi)) == pytest.approx(1 + off_map ** 3, rel=1e-12)


def test_beam_model_compares_with_the_range_cast_in_the_map():
    p = AmclParams(laser_max_beams=30, laser_model_type="beam", laser_sigma_hit=0.2)
    expected = (WALL_COL - 24) * RES          # Bresenham from the sensor's cell to the wall's: 1.8 m
    short = 1.71
    pz_short = (gauss(p, short - expected) + p.laser_z_short * p.laser_lambda_short
                * math.exp(-p.laser_lambda_short * short) + p.laser_z_rand / 4.0)
    pz_max = gauss(p, 4.0 - expected) + p.laser_z_max
    assert weight(p, scan([short, 4.0], increment=0.0)) == pytest.approx(1 + pz_short ** 3 + pz_max ** 3, rel=1e-12)


def test_a_reading_at_or_below_range_min_is_a_max_range_reading_and_beyond_range_max_none():
    params = AmclParams(laser_max_beams=30, laser_min_range=0.5, laser_max_range=3.0)
    raw = [0.05, 0.5, 0.6, 2.9, 3.0, 3.5, math.inf, -math.inf, math.nan]
    bearings, ranges, range_max = read_beams(scan(raw, increment=0.1), params)
    assert range_max == 3.0
    np.testing.assert_allclose(ranges, [3.0, 3.0, 0.6, 2.9, 3.0, 3.0])
    np.testing.assert_allclose(bearings, [0.0, 0.1, 0.2, 0.3, 0.4, 0.7])
    own = AmclParams(laser_max_beams=30)
    assert read_beams(scan(raw, increment=0.1), own)[2] == 4.0


@pytest.mark.parametrize("count, max_beams, model, step", [
    (683, 30, "likelihood_field", 682 // 29), (683, 30, "likelihood_field_prob", math.ceil(683 / 30)),
    (683, 683, "beam", 1), (683, 2000, "likelihood_field", 1), (100, 30, "likelihood_field", 99 // 29),
    (100, 30, "likelihood_field_prob", math.ceil(100 / 30))])
def test_beams_are_taken_at_amcls_step_from_the_first(count, max_beams, model, step):
    chosen = beam_indices(count, max_beams, model)
    np.testing.assert_array_equal(chosen, np.arange(0, count, step))


def test_the_robots_scan_with_30_beams_uses_30_of_683():
    chosen = beam_indices(683, 30, "likelihood_field")
    assert len(chosen) == 30 and chosen[-1] == 29 * (682 // 29)


def test_a_map_given_with_a_turned_origin_weighs_the_same():
    """The same room stored rotated by 90 degrees, its origin saying so, gives every particle the same weight."""
    rng = np.random.default_rng(1)
    data = wall_map()
    data[10:20, 30:45] = 100
    robots = np.column_stack((rng.uniform(0.5, 2.5, 20), rng.uniform(0.5, 2.5, 20), rng.uniform(-3, 3, 20)))
    ranges = rng.uniform(0.3, 3.5, 40)
    one_scan = scan(ranges, angle_min=-2.0, increment=0.1)
    for model in ("likelihood_field", "beam"):
        params = AmclParams(laser_max_beams=40, laser_model_type=model)
        straight = LaserModel(params, AmclMap(data, RES))
        # turned clockwise, old row r, column c is new row c, column H-1-r; the new grid's x axis points along
        # the old -y, from the old top left corner
        turned = LaserModel(params, AmclMap(np.rot90(data, k=-1), RES, (0.0, data.shape[0] * RES, -math.pi / 2)))
        np.testing.assert_allclose(turned.weights(turned.map.to_grid(robots), one_scan),
                                   straight.weights(straight.map.to_grid(robots), one_scan), rtol=1e-9)


def test_fewer_than_two_beams_leave_the_weights_alone():
    amcl = Amcl(AmclParams(laser_max_beams=1), wall_map(), RES)
    amcl.odometry_update((0.0, 0.0, 0.0))
    before = amcl.weights
    assert amcl.sensor_update([scan([1.71, 1.0])])
    np.testing.assert_array_equal(amcl.weights, before)


def test_a_malformed_scan_is_refused_naming_the_field():
    amcl = Amcl(AmclParams(), wall_map(), RES)
    with pytest.raises(ValueError, match="angle_increment"):
        amcl.sensor_update([scan([1.0]), RangeScan(np.ones(3), 0.0, math.nan, 0.1, 4.0)])
    with pytest.raises(ValueError, match="range_max"):
        amcl.sensor_update([RangeScan(np.ones(3), 0.0, 0.1, 0.1, 0.0)])
    with pytest.raises(ValueError, match="sensor_pose"):
        amcl.sensor_update([RangeScan(np.ones(3), 0.0, 0.1, 0.1, 4.0, (0.0, math.inf, 0.0))])
