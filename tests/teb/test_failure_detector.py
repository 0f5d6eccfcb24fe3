"""teb_local_planner's FailureDetector on command sequences."""

import pytest

from simplebot_navigation.teb.failure_detector import FailureDetector, buffer_length

LIMITS = dict(max_vel_x=0.4, max_vel_x_backwards=0.2, max_vel_theta=0.3, v_eps=0.1, omega_eps=0.1)


def feed(detector, commands):
    return [detector.update(v, omega, **LIMITS) for v, omega in commands]


def test_buffer_length_is_the_filter_duration_in_control_cycles():
    assert buffer_length(10.0, 0.05) == 200
    assert buffer_length(2.0, 1 / 3) == 6
    assert buffer_length(0.0, 0.1) == 0


def test_a_small_turn_rate_that_keeps_changing_sign_is_detected_once_the_buffer_is_half_full():
    detector = FailureDetector(20)
    states = feed(detector, [(0.01, 0.1 * (-1) ** k) for k in range(20)])
    assert states == [False] * 9 + [True] * 11


@pytest.mark.parametrize("commands", [
    [(0.0, 0.2)] * 20,                                    # turning on the spot
    [(0.3, 0.05 * (-1) ** k) for k in range(20)],         # driving, wobbling
    [(0.0, 0.1 * (-1) ** (k // 10)) for k in range(20)],  # one change of direction
    [(0.0, 6e-4 * (-1) ** k) for k in range(20)],         # standing: the optimiser's noise around zero
])
def test_a_steady_turn_driving_or_a_single_change_of_direction_is_no_oscillation(commands):
    assert not any(feed(FailureDetector(20), commands))


def test_speeds_are_fractions_of_their_limit_backwards_of_max_vel_x_backwards():
    # mean v of -0.03 m/s is 0.075 of max_vel_x but 0.15 of max_vel_x_backwards (oscillation_v_eps 0.1)
    backwards = [(-0.03, 0.1 * (-1) ** k) for k in range(10)]
    assert feed(FailureDetector(10), backwards)[-1] is False
    forwards = [(0.03, 0.1 * (-1) ** k) for k in range(10)]
    assert feed(FailureDetector(10), forwards)[-1] is True
    # mean omega 0.02 rad/s: 0.067 of max_vel_theta 0.3, 0.2 of 0.1
    biased = [(0.0, 0.02 + 0.1 * (-1) ** k) for k in range(10)]
    assert feed(FailureDetector(10), biased)[-1] is True
    detector = FailureDetector(10)
    assert not [detector.update(v, w, **{**LIMITS, "max_vel_theta": 0.1}) for v, w in biased][-1]


def test_clear_and_a_new_buffer_length():
    detector = FailureDetector(20)
    feed(detector, [(0.0, 0.1 * (-1) ** k) for k in range(12)])
    assert detector.oscillating
    detector.clear()
    assert not detector.oscillating
    assert not any(feed(detector, [(0.0, 0.1 * (-1) ** k) for k in range(9)]))
    detector.set_buffer_length(4)                         # the newest commands stay
    assert feed(detector, [(0.0, -0.1)]) == [True]
    detector.set_buffer_length(0)                         # oscillation_filter_duration 0: nothing to detect
    detector.clear()
    assert not any(feed(detector, [(0.0, 0.1 * (-1) ** k) for k in range(10)]))
