"""Wheel-level drive math: targets, saturation, ramps and odometry integration."""

import math

import numpy as np
import pytest

from simplebot_navigation.sim.diff_drive import DiffDriveParams, OdomNoise, WheelOdometry, ramp, wheel_targets

SEP, R = 0.46, 0.07


def test_wheel_targets_inverse_kinematics():
    left, right = wheel_targets(0.3, 0.5, SEP, R, max_speed=100.0)
    assert left == pytest.approx((0.3 - 0.5 * SEP / 2) / R)
    assert right == pytest.approx((0.3 + 0.5 * SEP / 2) / R)


def test_saturation_scales_both_wheels():
    left, right = wheel_targets(2.0, 1.0, SEP, R, max_speed=15.0)
    assert max(abs(left), abs(right)) == pytest.approx(15.0)
    # Same curvature as commanded: w / v = (right - left) / SEP / ((right + left) / 2).
    assert (right - left) / SEP / ((right + left) / 2) == pytest.approx(1.0 / 2.0)


def test_ramp_limits_the_larger_change_and_keeps_direction():
    current = np.array([1.0, 1.0])
    out = ramp(current, np.array([5.0, 3.0]), max_step=0.5)
    np.testing.assert_allclose(out, [1.5, 1.25])
    np.testing.assert_allclose(ramp(current, np.array([1.2, 0.9]), max_step=0.5), [1.2, 0.9])


def test_odometry_is_exact_on_a_constant_arc():
    odom = WheelOdometry(SEP, R)
    v, w = 0.4, 0.8
    speeds = wheel_targets(v, w, SEP, R, max_speed=100.0)
    for _ in range(250):
        odom.update(speeds, 0.01)
    t = 2.5
    radius = v / w
    assert (odom.x, odom.y) == pytest.approx((radius * math.sin(w * t), radius * (1 - math.cos(w * t))), abs=1e-12)
    assert odom.yaw == pytest.approx(w * t)
    assert (odom.v, odom.w) == pytest.approx((v, w))


def test_odometry_noise_is_seeded_drift():
    def final(seed):
        odom = WheelOdometry(SEP, R, OdomNoise(scale_std=0.01), np.random.default_rng(seed))
        for _ in range(500):
            odom.update((4.0, 4.0), 0.01)
        return odom.x, odom.y, odom.yaw

    assert final(3) == final(3)
    assert final(3) != final(4)
    x, y, yaw = final(3)
    assert abs(yaw) > 1e-4 and x == pytest.approx(4.0 * R * 5.0, rel=0.05)


@pytest.mark.parametrize("kwargs, message", [
    ({"max_wheel_speed": 0}, "DiffDriveParams.max_wheel_speed must be a positive number, got 0"),
    ({"max_wheel_accel": math.nan}, "DiffDriveParams.max_wheel_accel must be a positive number, got nan"),
    ({"cmd_timeout": "0.5"}, "DiffDriveParams.cmd_timeout must be a positive number, got '0.5'"),
])
def test_bad_drive_params(kwargs, message):
    with pytest.raises(ValueError, match=message):
        DiffDriveParams(**kwargs)


def test_bad_odom_noise():
    with pytest.raises(ValueError, match="OdomNoise.speed_std must be a number >= 0, got -0.1"):
        OdomNoise(speed_std=-0.1)
