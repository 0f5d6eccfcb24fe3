"""Wheel-level drive math: targets, saturation, ramps and odometry integration; which drive a body gets."""

import math

import numpy as np
import pytest

from simplebot_description import robot_description
from simplebot_navigation.sim.diff_drive import (
    JACKAL_ACCEL, JACKAL_MAX_SPEED, JACKAL_MAX_YAW_RATE, JACKAL_YAW_ACCEL, DiffDriveParams, OdomNoise, WheelOdometry,
    drive_for, jackal_drive, ramp, wheel_targets)

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


def test_the_yaw_rate_limit_saturates_along_the_curvature():
    left, right = wheel_targets(1.0, 6.0, SEP, R, max_speed=100.0, max_yaw_rate=4.0)
    v, w = (left + right) * R / 2, (right - left) * R / SEP
    assert (v, w) == pytest.approx((1.0 * 4.0 / 6.0, 4.0))
    # Within the limit nothing changes.
    np.testing.assert_allclose(wheel_targets(0.3, 0.5, SEP, R, 100.0, max_yaw_rate=4.0),
                               wheel_targets(0.3, 0.5, SEP, R, 100.0))


def test_ramp_limits_the_larger_change_and_keeps_direction():
    current = np.array([1.0, 1.0])
    out = ramp(current, np.array([5.0, 3.0]), max_step=0.5)
    np.testing.assert_allclose(out, [1.5, 1.25])
    np.testing.assert_allclose(ramp(current, np.array([1.2, 0.9]), max_step=0.5), [1.2, 0.9])


def test_ramp_limits_the_change_of_the_wheels_difference():
    current = np.array([0.0, 0.0])
    out = ramp(current, np.array([-4.0, 4.0]), max_step=3.0, max_turn_step=2.0)
    np.testing.assert_allclose(out, [-1.0, 1.0])
    # A straight change has no difference to limit.
    np.testing.assert_allclose(ramp(current, np.array([4.0, 4.0]), 3.0, max_turn_step=2.0), [3.0, 3.0])


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
    ({"max_yaw_rate": 0.0}, "DiffDriveParams.max_yaw_rate must be a positive number, got 0.0"),
    ({"max_yaw_accel": math.inf}, "DiffDriveParams.max_yaw_accel must be a positive number, got inf"),
])
def test_bad_drive_params(kwargs, message):
    with pytest.raises(ValueError, match=message):
        DiffDriveParams(**kwargs)


def test_bad_odom_noise():
    with pytest.raises(ValueError, match="OdomNoise.speed_std must be a number >= 0, got -0.1"):
        OdomNoise(speed_std=-0.1)


# -- which drive a body gets ------------------------------------------------------------------------

BOX = robot_description("box")
ROUND = robot_description("round", 0.25)


@pytest.mark.parametrize("description", [BOX, ROUND], ids=["box", "round"])
@pytest.mark.parametrize("max_speed", [None, 0.4, 1, 1.05])
def test_up_to_the_lab_drives_top_speed_every_body_keeps_it(description, max_speed):
    assert drive_for(description, max_speed) == DiffDriveParams()


@pytest.mark.parametrize("max_speed", [1.06, 1.5, 2, 2.0])
def test_above_it_the_round_body_gets_the_jackal_drive(max_speed):
    drive = drive_for(ROUND, max_speed)
    assert drive == jackal_drive(ROUND)
    r = ROUND.wheel_radius
    assert drive.max_wheel_speed * r == pytest.approx(JACKAL_MAX_SPEED)
    assert drive.max_wheel_accel * r == pytest.approx(JACKAL_ACCEL)
    assert (drive.max_yaw_rate, drive.max_yaw_accel) == (JACKAL_MAX_YAW_RATE, JACKAL_YAW_ACCEL)
    # The two wheels' torque at the rim accelerates the whole robot at twice the ramp's limit.
    assert 2 * drive.max_wheel_torque / r / ROUND.mass == pytest.approx(2 * JACKAL_ACCEL)
    # The wheels, not only the yaw limit, allow 4 rad/s on the spot.
    assert drive.max_wheel_speed * r / (ROUND.wheel_separation / 2) > JACKAL_MAX_YAW_RATE


@pytest.mark.parametrize("description, max_speed, message", [
    (BOX, 1.5, r"^1.5 m/s is above the box's top speed of 1.05 m/s \(the lab's drive; the round body's goes up to "
               r"2 m/s\)$"),
    (ROUND, 2.5, r"^2.5 m/s is above the round body's top speed of 2 m/s \(a Clearpath Jackal's\)$"),
    (ROUND, 0.0, r"^expected a positive number of m/s, got 0.0$"),
    (ROUND, -1, r"^expected a positive number of m/s, got -1$"),
    (ROUND, math.nan, r"^expected a positive number of m/s, got nan$"),
    (ROUND, math.inf, r"^expected a positive number of m/s, got inf$"),
    (ROUND, "fast", r"^expected a positive number of m/s, got 'fast'$"),
    (ROUND, True, r"^expected a positive number of m/s, got True$"),
])
def test_bad_top_speeds_are_refused_naming_the_value_and_the_limit(description, max_speed, message):
    with pytest.raises(ValueError, match=message):
        drive_for(description, max_speed)
