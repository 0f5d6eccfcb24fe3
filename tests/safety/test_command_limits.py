"""What the collision monitor's output may be: the drive's top speeds, its accelerations, a bounded rate."""

import pytest

from simplebot_navigation.safety.command_limits import SCAN_PERIOD_S, Ramp, RateLimit, brakes, clamp


def test_a_command_beyond_the_top_speeds_is_scaled_down_along_its_curvature():
    assert clamp(100.0, 10.0, 1.05, 4.0) == pytest.approx((1.05, 0.105))
    assert clamp(0.5, -8.0, 1.05, 4.0) == pytest.approx((0.25, -4.0))
    assert clamp(0.5, 0.2, 1.05, 4.0) == (0.5, 0.2)


def ramp(ref, target, dt):
    """What may follow the output ``ref`` (the reference) dt seconds later."""
    limiter = Ramp()
    limiter.ref, limiter.last = list(ref), list(ref)
    limiter.ref_time, limiter.last_time = [0.0, 0.0], 0.0
    return limiter.limit(target, dt, (1.75, 8.0))


def test_the_output_speeds_up_at_the_acceleration_and_slows_down_at_once():
    assert ramp((0.0, 0.0), (1.0, 0.0), 0.05) == pytest.approx((0.0875, 0.0))
    assert ramp((0.5, 0.5), (0.6, 1.0), 0.05) == pytest.approx((0.5875, 0.9))   # each by its acceleration
    assert ramp((0.5, 0.2), (0.0, 0.0), 0.0) == (0.0, 0.0)          # a stop, at once
    assert ramp((1.0, 0.0), (0.2, 0.0), 0.0) == (0.2, 0.0)
    assert ramp((0.5, 0.0), (-1.0, 0.0), 0.1) == (0.0, 0.0)         # a reversal: through zero at the acceleration
    assert ramp((0.0, 0.0), (1.0, 0.0), 60.0) == pytest.approx((1.75 * SCAN_PERIOD_S, 0.0))


def test_commands_between_two_scans_both_speed_up():
    """A planner at 20 Hz and scans at 10 Hz: the second command of a scan period is not held back."""
    limiter, out = Ramp(), []
    for k in range(10):
        for want in (0.05 * (2 * k + 1), 0.05 * (2 * k + 2)):   # 1 m/s^2 asked for
            limiter.published(limiter.limit((want, 0.01 * (-1) ** k), 0.1 * k, (1.75, 8.0)), 0.1 * k)
            out.append(limiter.last[0])       # a yaw rate flickering around zero holds nothing back
    assert out[1:] == pytest.approx([0.05 * (n + 2) for n in range(19)])


def test_commands_alternating_at_1_khz_hardly_move_the_robot():
    """+1, -1, +100, -100 m/s a millisecond apart with the monitor's time moving in 0.1 s steps (its scans)."""
    limiter, travel = Ramp(), 0.0
    for i in range(3000):
        now = 0.1 * (i // 100)
        want = clamp((1.0, -1.0, 100.0, -100.0)[i % 4], 0.0, 1.05, 4.0)
        out = limiter.limit(want, now, (1.75, 8.0))
        limiter.published(out, now)
        travel += out[0] * 0.001
    assert abs(travel) < 0.01


def test_the_rate_limit_lets_braking_through_and_holds_the_rest_to_the_rate():
    rate = RateLimit()
    passed = sum(rate.allow(10.0, 50.0) for _ in range(1000))        # a flood within one scan period
    assert passed == 6                                               # 1 + 50 Hz x 0.1 s
    assert sum(rate.allow(10.0 + 0.1 * k, 50.0) for k in range(1, 11) for _ in range(100)) \
        == pytest.approx(50, abs=1)                                  # a second: 50
    assert brakes((0.5, 0.2), (0.0, 0.0)) and brakes((0.5, 0.2), (0.25, 0.1))
    assert not brakes((0.0, 0.0), (0.0, 0.0)) and not brakes((0.5, 0.2), (-0.1, 0.0))
