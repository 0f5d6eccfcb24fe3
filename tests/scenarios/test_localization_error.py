"""amcl's error against ground truth: each estimate compared with the truth at its own stamp."""

import math

import numpy as np
import pytest

from simplebot_navigation.scenarios.localization import errors_against_truth, localization_error


def test_each_estimate_meets_the_truth_interpolated_at_its_stamp():
    truth = [(0.0, 0.0, 0.0, 3.1), (1.0, 1.0, 0.0, -3.1)]       # yaw crosses +-pi
    position, heading = errors_against_truth([(0.5, 0.5, 0.03, math.pi), (2.0, 9.0, 9.0, 0.0)], truth)
    assert position == pytest.approx([0.03])                     # the second is after the truth ends
    assert heading == pytest.approx([0.0], abs=1e-9)


def test_statistics_over_a_goal():
    truth = np.column_stack([np.arange(11.0), np.zeros(11), np.zeros(11), np.zeros(11)])
    estimates = [(t, 0.0, 0.1 if t == 10 else 0.0, 0.02) for t in range(11)]
    error = localization_error(estimates, truth)
    assert error.samples == 11 and error.position_max == pytest.approx(0.1)
    assert error.position_rms == pytest.approx(math.sqrt(0.01 / 11))
    assert error.yaw_rms == pytest.approx(0.02)
    assert "cm RMS" in error.text()
    assert localization_error([], truth) is None
