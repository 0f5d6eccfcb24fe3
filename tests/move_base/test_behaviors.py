"""Nav2's Spin, BackUp/DriveOnHeading and Wait as move_base steps them, on an ideal diff-drive robot, and the bounds
on what a request may ask."""

import math

import numpy as np
import pytest

from simplebot_navigation.move_base.behaviors import (MAX_SPIN_RAD, BehaviorServerParams, DriveOnHeadingBehavior,
                                                      SpinBehavior, WaitBehavior, check_drive, check_spin, check_time)
from simplebot_navigation.parameters import ParameterError

DT = 0.05
NAV2 = BehaviorServerParams()      # Nav2 behavior_server's defaults


def drive(behavior, pose=(0.0, 0.0, 0.0), seconds=60.0):
    """Step a behaviour; returns the final pose and the last step."""
    t = 0.0
    behavior.start(t, pose)
    for _ in range(int(seconds / DT)):
        step = behavior.tick(t, pose)
        if step.outcome is not None:
            return pose, step
        v, omega = step.cmd
        x, y, yaw = pose
        pose = (x + v * DT * math.cos(yaw), y + v * DT * math.sin(yaw), math.remainder(yaw + omega * DT, 2 * math.pi))
        t += DT
    raise AssertionError("the behaviour never ended")


def free(poses):
    return np.ones(len(poses), dtype=bool)


def wall_beyond_x(x_wall):
    return lambda poses: np.asarray(poses)[:, 0] < x_wall


@pytest.mark.parametrize("target", [math.pi / 2, -math.pi, 3 * math.pi])
def test_spin_turns_the_signed_target_more_than_once_round_if_asked(target):
    spin = SpinBehavior(target, 30.0, free, NAV2)
    pose, step = drive(spin)
    assert step.outcome == ""
    assert spin.turned == pytest.approx(target, abs=0.03)
    assert math.remainder(pose[2] - target, 2 * math.pi) == pytest.approx(0.0, abs=0.03)


def test_spin_ends_with_collision_ahead_before_the_footprint_would_touch():
    blocked_from = 0.8     # rad: a footprint corner would touch an obstacle from this yaw on
    spin = SpinBehavior(math.pi, 30.0, lambda poses: np.asarray(poses)[:, 2] < blocked_from, NAV2)
    pose, step = drive(spin)
    assert step.outcome == "COLLISION_AHEAD" and "collision ahead" in step.message
    assert pose[2] < blocked_from


def test_spin_gives_up_after_its_time_allowance():
    _, step = drive(SpinBehavior(2 * math.pi, 1.0, free, NAV2))
    assert step.outcome == "TIMEOUT" and "time_allowance" in step.message


@pytest.mark.parametrize("distance, speed", [(0.3, -0.15), (1.0, 0.5)])
def test_drive_on_heading_drives_the_distance_straight(distance, speed):
    behavior = DriveOnHeadingBehavior(distance, speed, 30.0, free, DT, NAV2)
    pose, step = drive(behavior, (1.0, 2.0, math.pi / 2))
    assert step.outcome == ""
    moved = pose[1] - 2.0
    assert moved == pytest.approx(math.copysign(distance, speed), abs=0.01)   # no overshoot past the end
    assert pose[0] == pytest.approx(1.0, abs=1e-9)


def test_backing_up_towards_a_wall_stops_short_of_it_with_collision_ahead():
    behavior = DriveOnHeadingBehavior(2.0, -0.25, 30.0, lambda poses: np.asarray(poses)[:, 0] > -0.8, DT,
                                      NAV2)
    pose, step = drive(behavior)
    assert step.outcome == "COLLISION_AHEAD"
    assert -0.8 < pose[0] < 0.0


def test_wait_counts_down_and_never_moves():
    wait = WaitBehavior(1.0)
    wait.start(0.0, (0, 0, 0))
    assert wait.tick(0.4, (0, 0, 0)).outcome is None and wait.time_left == pytest.approx(0.6)
    step = wait.tick(1.0, (0, 0, 0))
    assert step.outcome == "" and step.cmd == (0.0, 0.0)


@pytest.mark.parametrize("request_, field", [
    ((1e9, 10.0), "target_yaw"), ((math.nan, 10.0), "target_yaw"), ((MAX_SPIN_RAD + 0.1, 10.0), "target_yaw"),
    ((1.0, 0.0), "time_allowance"), ((1.0, math.inf), "time_allowance")])
def test_a_spin_that_cannot_run_names_the_field(request_, field):
    assert field in check_spin(*request_)


def test_a_spin_within_bounds_is_taken():
    assert check_spin(-MAX_SPIN_RAD, 3600.0) is None


@pytest.mark.parametrize("request_, backup, field", [
    ((-0.3, 0, 0, 0.1, 10), True, "target.x"), ((0.3, 0.1, 0, 0.1, 10), True, "target.y"),
    ((0.3, 0, 0, 0.0, 10), True, "speed"), ((0.3, 0, 0, 5.0, 10), True, "speed"),
    ((0.3, 0, 0, 0.1, 0), True, "time_allowance"), ((1e308, 0, 0, 0.1, 10), True, "target.x"),
    ((math.nan, 0, 0, 0.1, 10), False, "target.x"), ((1.0, 0, 0, -0.2, 10), False, "same sign")])
def test_a_drive_that_cannot_run_names_the_field(request_, backup, field):
    assert field in check_drive(*request_, backup=backup)


def test_backing_up_takes_a_negative_speed_as_nav2_does():
    assert check_drive(0.3, 0, 0, -0.1, 10, backup=True) is None
    assert check_drive(-0.5, 0, 0, -0.2, 10, backup=False) is None


def test_a_wait_of_zero_or_of_a_year_is_refused():
    assert "time" in check_time(0.0, "time") and "time" in check_time(3.2e7, "time")


# -- behavior_server's parameters ------------------------------------------------------------------------------

def turn_rates(spin):
    """Every turn rate a spin commands on its way."""
    rates, t, pose = [], 0.0, (0.0, 0.0, 0.0)
    spin.start(t, pose)
    while (step := spin.tick(t, pose)).outcome is None:
        rates.append(abs(step.cmd[1]))
        pose = (0.0, 0.0, pose[2] + step.cmd[1] * DT)
        t += DT
    assert step.outcome == "", step.message
    return rates


def test_a_lower_max_rotational_vel_slows_the_spin_down():
    assert max(turn_rates(SpinBehavior(math.pi, 30.0, free, NAV2))) == pytest.approx(1.0)
    slow = turn_rates(SpinBehavior(math.pi, 30.0, free, BehaviorServerParams(max_rotational_vel=0.5)))
    assert max(slow) == pytest.approx(0.5) and all(rate <= 0.5 for rate in slow)


def test_min_rotational_vel_and_rotational_acc_lim_shape_the_end_of_the_spin():
    gentle = BehaviorServerParams(min_rotational_vel=0.1, rotational_acc_lim=0.5)
    assert min(turn_rates(SpinBehavior(math.pi, 30.0, free, NAV2))) >= 0.4
    rates = turn_rates(SpinBehavior(math.pi, 30.0, free, gentle))
    assert 0.1 <= min(rates) < 0.3                                # it creeps up to the end
    slowing_from = next(i for i, rate in enumerate(rates) if rate < 1.0)
    assert (len(rates) - slowing_from) * DT > 1.5                 # about sqrt(2 * 1 / 0.5) = 2 s instead of 0.3 s


def test_a_shorter_simulate_ahead_time_backs_up_nearer_an_obstacle():
    def back_up(params):
        wall = lambda poses: np.asarray(poses)[:, 0] > -0.8      # noqa: E731 - an obstacle 0.8 m behind
        pose, step = drive(DriveOnHeadingBehavior(2.0, -0.25, 30.0, wall, DT, params))
        assert step.outcome == "COLLISION_AHEAD"
        return pose[0]

    nav2, short = back_up(NAV2), back_up(BehaviorServerParams(simulate_ahead_time=0.5))
    assert nav2 > -0.35                          # it stops 2 s (0.5 m) short of the obstacle
    assert -0.8 < short < -0.6                   # 0.5 s (0.125 m) short of it


def test_a_shorter_simulate_ahead_time_spins_nearer_an_obstacle():
    blocked_from = 1.5
    ends = [drive(SpinBehavior(math.pi, 30.0, lambda poses: np.asarray(poses)[:, 2] < blocked_from, params))[0][2]
            for params in (NAV2, BehaviorServerParams(simulate_ahead_time=0.2))]
    assert ends[0] == 0.0                        # 2 s at 1 rad/s reach the obstacle: it does not even start
    assert 1.2 < ends[1] < blocked_from


@pytest.mark.parametrize("given, message", [
    ({"max_rotational_vel": 0.0}, r"behavior_server/max_rotational_vel: must be in \(0, 6\], got 0.0"),
    ({"max_rotational_vel": 10.0}, r"behavior_server/max_rotational_vel: must be in \(0, 6\], got 10.0"),
    ({"min_rotational_vel": -0.1}, r"behavior_server/min_rotational_vel: must be in \[0, 6\], got -0.1"),
    ({"rotational_acc_lim": 0}, r"behavior_server/rotational_acc_lim: must be in \(0, 50\], got 0.0"),
    ({"simulate_ahead_time": 0.0}, r"behavior_server/simulate_ahead_time: must be in \(0, 10\], got 0.0"),
    ({"simulate_ahead_time": math.nan}, r"behavior_server/simulate_ahead_time: expected a number \(finite\)"),
    ({"max_rotational_vel": 0.3}, r"behavior_server/min_rotational_vel: must be at most max_rotational_vel \(0.3\)"),
])
def test_a_behavior_server_value_out_of_range_is_refused_naming_it(given, message):
    with pytest.raises(ParameterError, match=message):
        BehaviorServerParams.from_params(given)


def test_the_defaults_are_nav2_behavior_servers():
    params = BehaviorServerParams.from_params({})
    assert (params.simulate_ahead_time, params.max_rotational_vel, params.min_rotational_vel,
            params.rotational_acc_lim) == (2.0, 1.0, 0.4, 3.2)
