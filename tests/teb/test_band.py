import math

import numpy as np
import pytest

from simplebot_navigation.teb.band import TimedElasticBand


def random_band(n: int, seed: int) -> TimedElasticBand:
    rng = np.random.default_rng(seed)
    poses = np.column_stack([np.cumsum(rng.uniform(0, 0.2, n + 1)), rng.uniform(-0.1, 0.1, n + 1),
                             rng.uniform(-0.5, 0.5, n + 1)])
    return TimedElasticBand(poses, rng.uniform(0.001, 0.5, n))


@pytest.mark.parametrize("seed", range(5))
def test_auto_resize_keeps_every_dt_within_hysteresis(seed):
    # the setting of teb_local_planner's own unit test: autoResize(0.1, 0.1/3, 3, 100)
    dt, hyst = 0.1, 0.1 / 3
    band = random_band(30, seed)          # about 7.5 s of band: fits in max_samples = 100
    total = band.sum_of_time_diffs
    start, goal = band.poses[0].copy(), band.poses[-1].copy()
    band.auto_resize(dt, hyst, 3, 100, fast_mode=False)
    # the first interval is split or merged but never retimed in place (see
    # test_resizing_does_not_retime_the_first_segment_under_its_poses): up to 2 dt_ref
    assert np.all(np.abs(band.time_diffs[1:] - dt) <= hyst + 1e-3)
    assert dt - hyst - 1e-3 <= band.time_diffs[0] <= 2 * dt + 1e-9
    assert len(band.poses) == len(band.time_diffs) + 1
    np.testing.assert_array_equal(band.poses[0], start)
    np.testing.assert_array_equal(band.poses[-1], goal)
    # only the clamp of an over-long final interval may drop time
    assert band.sum_of_time_diffs <= total + 1e-9


def test_auto_resize_splits_long_intervals_at_the_average_pose():
    band = TimedElasticBand(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.4], [2.0, 0.0, 0.4]]), np.array([1.0, 0.3]))
    band.auto_resize(0.3, 0.2, 3, 500, fast_mode=True)
    np.testing.assert_allclose(band.time_diffs, [0.5, 0.5, 0.3])
    np.testing.assert_allclose(band.poses[1], [0.5, 0.0, 0.2])


def test_auto_resize_respects_min_samples():
    band = TimedElasticBand(np.column_stack([np.linspace(0, 0.3, 4), np.zeros(4), np.zeros(4)]), np.full(3, 0.01))
    band.auto_resize(0.3, 0.1, 3, 500, fast_mode=False)
    assert len(band.time_diffs) == 3


def test_init_from_path_estimates_time_and_orientation():
    path = np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 1.0], [0.4, 0.4, 2.0], [0.8, 0.4, 0.0]])
    band = TimedElasticBand()
    band.init_from_path(path, max_vel_x=0.4, max_vel_theta=0.3, estimate_orientation=True,
                        min_samples=3, guess_backwards_motion=False)
    # intermediate yaw = direction to the next plan point; start and goal keep theirs
    np.testing.assert_allclose(band.poses[:, 2], [0.0, math.pi / 2, 0.0, 0.0])
    # dT = max(distance / max_vel_x, |dyaw| / max_vel_theta)
    np.testing.assert_allclose(band.time_diffs, [max(1.0, (math.pi / 2) / 0.3), max(1.0, (math.pi / 2) / 0.3), 1.0])


def test_init_inserts_poses_up_to_min_samples():
    band = TimedElasticBand()
    band.init_from_path(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), 0.4, 0.3, True, 5, False)
    assert len(band.poses) == 5
    np.testing.assert_allclose(band.poses[:, 0], [0.0, 0.5, 0.75, 0.875, 1.0])


def test_warm_start_prunes_passed_poses_and_pins_start_and_goal():
    poses = np.column_stack([np.arange(8) * 0.1, np.zeros(8), np.zeros(8)])
    band = TimedElasticBand(poses, np.full(7, 0.25))
    band.update_and_prune(np.array([0.31, 0.02, 0.1]), np.array([0.7, 0.05, 0.0]), min_samples=3)
    np.testing.assert_allclose(band.poses[0], [0.31, 0.02, 0.1])
    np.testing.assert_allclose(band.poses[1:-1, 0], [0.4, 0.5, 0.6])
    np.testing.assert_allclose(band.poses[-1], [0.7, 0.05, 0.0])
    assert len(band.time_diffs) == 4


@pytest.mark.parametrize("driven", [0.05, 0.1])
def test_warm_start_gives_the_first_segment_the_time_left_on_the_old_band(driven):
    # 2 m/s with poses 0.15 m apart (dt_ref 0.075 s); the robot drove `driven` since the last
    # cycle. TEB kept the old first interval (0.075 s) for whatever was left: 0.1 m (1.33 m/s) or, with pose 1
    # dropped, 0.2 m (2.67 m/s), so the commanded speed alternated from cycle to cycle.
    poses = np.column_stack([np.arange(12) * 0.15, np.zeros(12), np.zeros(12)])
    band = TimedElasticBand(poses, np.full(11, 0.075))
    band.update_and_prune(np.array([driven, 0.0, 0.0]), poses[-1], min_samples=3)
    first = math.hypot(*(band.poses[1, :2] - band.poses[0, :2])) / band.time_diffs[0]
    assert first == pytest.approx(2.0)
    np.testing.assert_allclose(band.time_diffs[1:], 0.075)


def test_a_turn_on_the_spot_keeps_its_time_at_a_warm_start():
    poses = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, 1.0], [0.5, 0.5, 1.0]])
    band = TimedElasticBand(poses, np.array([0.25, 0.25, 0.5]))
    band.update_and_prune(np.array([0.0, 0.0, 0.2]), poses[-1], min_samples=3)
    np.testing.assert_allclose(band.time_diffs, [0.25, 0.25, 0.5])


def test_resizing_does_not_retime_the_first_segment_under_its_poses():
    # dt_0 between dt_ref + dt_hysteresis and 2 dt_ref: upstream sets it to dt_ref and hands the rest to dt_1,
    # the poses staying where they are, so the first segment (the command) jumps from 2.0 to 2.67 m/s
    poses = np.column_stack([np.arange(6) * 0.2, np.zeros(6), np.zeros(6)])
    band = TimedElasticBand(poses, np.full(5, 0.1))
    band.auto_resize(0.075, 0.0075, 3, 100, fast_mode=True)
    assert band.poses[1, 0] / band.time_diffs[0] == pytest.approx(2.0)
    np.testing.assert_allclose(band.time_diffs[1:4], 0.075)       # the later ones are, as upstream does
