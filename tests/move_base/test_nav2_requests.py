"""What Nav2's navigation actions add to a goal: pose count bounds, the remaining distance and the time estimate."""

import math

import pytest

from simplebot_navigation.move_base.nav2_requests import (DEFAULT_SPEED, MAX_POSES, ProgressEstimate,
                                                          check_pose_count, remaining_distance)


def test_an_empty_list_and_ten_thousand_poses_are_refused_naming_the_field():
    assert "poses is empty" in check_pose_count(0)
    assert "10000 poses" in check_pose_count(10_000) and str(MAX_POSES) in check_pose_count(10_000)
    assert check_pose_count(MAX_POSES) is None


def test_remaining_distance_follows_the_plan_then_the_later_poses():
    assert remaining_distance(None, (0, 0, 0), (3, 4, 0), []) == pytest.approx(5.0)
    assert remaining_distance(7.5, (0, 0, 0), (3, 4, 0), [(3, 6), (0, 6)]) == pytest.approx(7.5 + 2 + 3)


def test_the_estimate_uses_the_recent_speed():
    estimate = ProgressEstimate()
    for i in range(41):                      # 0.5 m/s for 4 s, sampled at 10 Hz
        estimate.add(i * 0.1, 0.05 * i, 0.0)
    assert estimate.speed() == pytest.approx(0.5, rel=0.05)
    assert estimate.time_remaining(3.0) == pytest.approx(6.0, rel=0.05)


def test_a_standing_robot_is_estimated_at_its_top_speed_not_forever():
    estimate = ProgressEstimate()
    for i in range(21):
        estimate.add(i * 0.1, 0.08 * i, 0.0)          # 0.8 m/s
    estimate.time_remaining(1.0)
    for i in range(21, 60):
        estimate.add(i * 0.1, 1.6, 0.0)              # then it waits
    assert estimate.speed() < 0.05
    assert estimate.time_remaining(4.0) == pytest.approx(5.0, rel=0.05)
    assert math.isfinite(ProgressEstimate().time_remaining(2.0))
    assert ProgressEstimate().time_remaining(2.0) == pytest.approx(2.0 / DEFAULT_SPEED)


def test_time_going_back_starts_the_speed_afresh():
    estimate = ProgressEstimate()
    estimate.add(10.0, 0.0, 0.0)
    estimate.add(11.0, 1.0, 0.0)
    estimate.add(0.5, 50.0, 0.0)
    assert estimate.speed() == 0.0
