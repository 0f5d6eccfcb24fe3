"""What the collision monitor's output may be: the drive's top speeds, its accelerations, a bounded rate."""

import pytest

from simplebot_navigation.safety.command_limits import SCAN_PERIOD_S, RateLimit, brakes, clamp, ramp


def test_a_command_beyond_the_top_speeds_is_scaled_down_along_its_curvature():
    assert clamp(100.0, 10.0, 1.05, 4.0) == pytest.approx((1.05, 0.105))
    assert clamp(0.5, -8.0, 1.05, 4.0) == pytest.approx((0.25, -4.0))
    assert clamp(0.5, 0.2, 1.05, 4.0) == (0.5, 0.2)


def test_the_output_speeds_up_at_the_acceleration_and_slows_down_at_once():
    assert ramp((0.0, 0.0), (1.0, 0.0), 0.05, 1.75, 8.0) == pytest.approx((0.0875, 0.0))
    # the yaw rate may grow by 0.4 rad/s in 0.05 s, not 0.5: both are scaled, the curvature stays
    assert ramp((0.5, 0.5), (0.6, 1.0), 0.05, 1.75, 8.0) == pytest.approx((0.54, 0.9))
    assert ramp((0.5, 0.2), (0.0, 0.0), 0.0, 1.75, 8.0) == (0.0, 0.0)          # a stop, at once
    assert ramp((1.0, 0.0), (0.2, 0.0), 0.0, 1.75, 8.0) == (0.2, 0.0)
    assert ramp((0.0, 0.0), (1.0, 0.0), 60.0, 1.75, 8.0) == pytest.approx((1.75 * SCAN_PERIOD_S, 0.0))


def test_commands_alternating_at_1_khz_hardly_move_the_robot():
    """+1 and -1 m/s a millisecond apart with the monitor's time moving in 0.1 s steps (its scans)."""
    out, at, travel = (0.0, 0.0), 0.0, 0.0
    for i in range(3000):
        now = 0.1 * (i // 100)
        new = ramp(out, (1.0 if i % 2 else -1.0, 0.0), now - at, 1.75, 8.0)
        travel += new[0] * 0.001
        out, at = new, now
    assert abs(travel) < 0.01


def test_the_rate_limit_lets_braking_through_and_holds_the_rest_to_the_rate():
    rate = RateLimit()
    passed = sum(rate.allow(10.0, 50.0) for _ in range(1000))        # a flood within one scan period
    assert passed == 6                                               # 1 + 50 Hz x 0.1 s
    assert sum(rate.allow(10.0 + 0.1 * k, 50.0) for k in range(1, 11) for _ in range(100)) \
        == pytest.approx(50, abs=1)                                  # a second: 50
    assert brakes((0.5, 0.2), (0.0, 0.0)) and brakes((0.5, 0.2), (0.25, 0.1))
    assert not brakes((0.0, 0.0), (0.0, 0.0)) and not brakes((0.5, 0.2), (-0.1, 0.0))
