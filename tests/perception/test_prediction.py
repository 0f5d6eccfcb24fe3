"""The keep-out region of a predicted obstacle (perception/prediction.py): how it grows with time and with the
track's covariance, where it stops, and which covariances are accepted."""

import math

import numpy as np
import pytest

from simplebot_navigation.perception.prediction import (MotionPrediction, full_rows, largest_sigma, prediction_rows,
                                                        valid_covariances)

TIMES = np.linspace(0.0, 8.0, 81)


def covariance(position_sigma: float, velocity_sigma: float, count: int = 1) -> np.ndarray:
    return np.tile(np.diag([position_sigma ** 2] * 2 + [velocity_sigma ** 2] * 2), (count, 1, 1))


def walker(position_sigma: float, velocity_sigma: float, n_sigma: float = 2.0) -> np.ndarray:
    """A 0.3 m person at (1, 2) walking at 1 m/s along x, as prediction rows."""
    return prediction_rows(np.array([[1.0, 2.0, 1.0, 0.0, 0.3]]), covariance(position_sigma, velocity_sigma), n_sigma)


def test_the_radius_grows_with_time_and_with_the_covariance_up_to_the_cap():
    prediction = MotionPrediction(max_uncertainty=0.5)
    small, large = prediction.radii(walker(0.02, 0.1), TIMES)[0], prediction.radii(walker(0.05, 0.3), TIMES)[0]
    assert np.all(np.diff(small) >= 0) and np.all(np.diff(large) >= 0)
    assert np.all(large >= small) and large[10] > small[10]
    assert small[0] == pytest.approx(0.3 + 2 * 0.02) and large[0] == pytest.approx(0.3 + 2 * 0.05)
    assert small[10] == pytest.approx(0.3 + 2 * math.hypot(0.02, 0.1))                 # at 1 s
    assert large.max() == pytest.approx(0.8) and small.max() == pytest.approx(0.8)     # both reach the cap


def test_a_new_track_does_not_block_everything():
    # 1 m/s velocity sigma (a track just started): 3 sigmas would add 9 m by 3 s without the cap
    radii = MotionPrediction(max_uncertainty=0.3).radii(walker(0.03, 1.0, n_sigma=3.0), TIMES)[0]
    assert radii.max() == pytest.approx(0.6)


def test_the_radius_growth_adds_per_second_on_top_of_the_capped_uncertainty():
    rows = walker(0.05, 0.3)
    with_growth = MotionPrediction(max_uncertainty=0.2, radius_growth=0.1).radii(rows, TIMES)[0]
    without = MotionPrediction(max_uncertainty=0.2).radii(rows, TIMES)[0]
    np.testing.assert_allclose(with_growth - without, 0.1 * TIMES)


def test_beyond_the_horizon_the_obstacle_walks_on_and_its_circle_stops_growing():
    """Held where it is at the horizon, a person crossing the robot's path would stand there in the prediction
    while it walks on, and a plan passing behind that place would meet it."""
    prediction = MotionPrediction(horizon=3.0, max_uncertainty=5.0, radius_growth=0.1)
    rows = walker(0.05, 0.3)
    radii = prediction.radii(rows, TIMES)[0]
    later = TIMES >= 3.0
    assert np.all(radii[later] == radii[later][0]) and np.all(np.diff(radii[~later]) > 0)
    unlimited = MotionPrediction(max_uncertainty=5.0, radius_growth=0.1)
    np.testing.assert_array_equal(radii[~later], unlimited.radii(rows, TIMES[~later])[0])
    np.testing.assert_array_equal(prediction.centres(rows, TIMES), unlimited.centres(rows, TIMES))
    assert prediction.centres(rows, TIMES)[0, -1, 0] == pytest.approx(9.0)


def test_no_covariance_and_no_growth_leave_the_radius_and_the_motion_exactly_as_tracked():
    tracked = np.array([[1.0, 2.0, 0.7, -0.3, 0.31], [-4.0, 0.5, 0.0, 1.2, 0.45]])
    rows = prediction_rows(tracked, np.zeros((2, 4, 4)), 3.0)
    prediction = MotionPrediction(max_uncertainty=0.3)
    np.testing.assert_array_equal(prediction.radii(rows, TIMES), np.repeat(tracked[:, 4:5], len(TIMES), axis=1))
    np.testing.assert_array_equal(prediction.centres(rows, TIMES),
                                  tracked[:, None, :2] + TIMES[None, :, None] * tracked[:, None, 2:4])
    np.testing.assert_array_equal(full_rows(tracked), prediction_rows(tracked, None, 3.0))


def test_the_spread_is_the_largest_standard_deviation_of_each_block():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(20, 4, 4))
    cov = a @ a.transpose(0, 2, 1)
    np.testing.assert_allclose(largest_sigma(cov[:, :2, :2]), np.sqrt(np.linalg.eigvalsh(cov[:, :2, :2])[:, -1]))
    rows = prediction_rows(np.zeros((20, 5)), cov, 2.0)
    np.testing.assert_allclose(rows[:, 6], 2.0 * np.sqrt(np.linalg.eigvalsh(cov[:, 2:, 2:])[:, -1]))


def test_only_finite_symmetric_positive_semidefinite_matrices_are_covariances():
    good = covariance(0.03, 0.2, 6)
    good[1] = 0.0                                              # a source without covariances sends zeros
    good[2, 0, 2] = good[2, 2, 0] = 0.5 * 0.03 * 0.2           # correlated
    good[3, 0, 0] = np.nan
    good[4, 0, 1] = 0.1                                        # not symmetric
    good[5, 2, 2] = -0.01                                      # a negative variance
    np.testing.assert_array_equal(valid_covariances(good), [True, True, True, False, False, False])
    assert valid_covariances(np.zeros((0, 4, 4))).shape == (0,)
