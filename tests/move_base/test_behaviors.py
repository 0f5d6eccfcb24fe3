"""Nav2's Spin, BackUp/DriveOnHeading and Wait as move_base steps them, on an ideal diff-drive robot, and the bounds
on what a request may ask."""

import math

import numpy as np
import pytest

from simplebot_navigation.move_base.behaviors import (MAX_SPIN_RAD, DriveOnHeadingBehavior, SpinBehavior, WaitBehavior,
                                                      check_drive, check_spin, check_time)

DT = 0.05


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
    spin = SpinBehavior(target, 30.0, free)
    pose, step = drive(spin)
    assert step.outcome == ""
    assert spin.turned == pytest.approx(target, abs=0.03)
    assert math.remainder(pose[2] - target, 2 * math.pi) == pytest.approx(0.0, abs=0.03)


def test_spin_ends_with_collision_ahead_before_the_footprint_would_touch():
    blocked_from = 0.8     # rad: a footprint corner would touch an obstacle from this yaw on
    spin = SpinBehavior(math.pi, 30.0, lambda poses: np.asarray(poses)[:, 2] < blocked_from)
    pose, step = drive(spin)
    assert step.outcome == "COLLISION_AHEAD" and "collision ahead" in step.message
    assert pose[2] < blocked_from


def test_spin_gives_up_after_its_time_allowance():
    _, step = drive(SpinBehavior(2 * math.pi, 1.0, free))
    assert step.outcome == "TIMEOUT" and "time_allowance" in step.message


@pytest.mark.parametrize("distance, speed", [(0.3, -0.15), (1.0, 0.5)])
def test_drive_on_heading_drives_the_distance_straight(distance, speed):
    behavior = DriveOnHeadingBehavior(distance, speed, 30.0, free, DT)
    pose, step = drive(behavior, (1.0, 2.0, math.pi / 2))
    assert step.outcome == ""
    moved = pose[1] - 2.0
    assert moved == pytest.approx(math.copysign(distance, speed), abs=0.01)   # no overshoot past the end
    assert pose[0] == pytest.approx(1.0, abs=1e-9)


def test_backing_up_towards_a_wall_stops_short_of_it_with_collision_ahead():
    behavior = DriveOnHeadingBehavior(2.0, -0.25, 30.0, lambda poses: np.asarray(poses)[:, 0] > -0.8, DT)
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
