"""Hostile cmd_vel values: the drive saturates or refuses them, and the simulated robot stays finite."""

import math

import numpy as np
import pytest

from simplebot_description import robot_description
from simplebot_navigation.sim import DiffDriveParams, SimplebotSim, World
from simplebot_navigation.sim.diff_drive import WheelOdometry, wheel_targets

SEP, R, MAX = 0.46, 0.07, 15.0


@pytest.mark.parametrize("v, w", [(1e308, 0.0), (-1e308, 0.0), (0.0, 1e308), (1e308, 1e308),
                                  (-1.7e308, 1.7e308), (1e308, 5e-324)])
def test_huge_commands_saturate_at_the_top_wheel_speed(v, w):
    left, right = wheel_targets(v, w, SEP, R, MAX)
    assert math.isfinite(left) and math.isfinite(right)
    assert max(abs(left), abs(right)) == pytest.approx(MAX)


def test_a_huge_command_keeps_its_curvature():
    small = wheel_targets(2.0, 1.0, SEP, R, MAX)
    huge = wheel_targets(2.0e307, 1.0e307, SEP, R, MAX)
    np.testing.assert_allclose(huge, small, rtol=1e-9)


@pytest.mark.parametrize("v, w", [(math.nan, 0.0), (0.0, math.inf), (-math.inf, 1.0)])
def test_non_finite_commands_are_refused(v, w):
    with pytest.raises(ValueError, match="cmd_vel must be finite"):
        wheel_targets(v, w, SEP, R, MAX)


@pytest.mark.parametrize("speeds, dt", [((math.nan, 1.0), 0.01), ((1.0, math.inf), 0.01), ((1.0, 1.0), math.nan)])
def test_odometry_refuses_non_finite_input_and_keeps_its_pose(speeds, dt):
    odom = WheelOdometry(SEP, R)
    odom.update((4.0, 4.0), 0.5)
    before = (odom.x, odom.y, odom.yaw, odom.v, odom.w)
    with pytest.raises(ValueError, match="wheel odometry"):
        odom.update(speeds, dt)
    assert (odom.x, odom.y, odom.yaw, odom.v, odom.w) == before


def test_simulator_survives_a_1e308_cmd_vel():
    sim = SimplebotSim(World("empty"), robot_description("box"))
    try:
        sim.set_cmd_vel(1e308, 0.0)
        sim.step_until(1.0)
        sim.set_cmd_vel(0.0, 0.0)
        sim.step_until(2.0)
        odom, truth = sim.odometry(), sim.ground_truth()
        values = (odom.x, odom.y, odom.yaw, odom.vx, odom.wz, truth.x, truth.y, truth.yaw)
        assert all(math.isfinite(value) for value in values), values
        # It drove forward at the drive's top speed, then stopped.
        top_speed = DiffDriveParams().max_wheel_speed * robot_description("box").wheel_radius
        assert 0.3 < truth.x < top_speed * 1.0 and abs(truth.y) < 0.05
        assert abs(odom.vx) < 0.01
    finally:
        sim.close()
