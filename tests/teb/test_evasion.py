"""Evasion of predicted collisions (teb/evasion.py): the rollouts, the contact times, and the closed
loop where a standstill would be hit."""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.footprint import footprint_from_radius
from simplebot_navigation.perception.prediction import MotionPrediction
from simplebot_navigation.teb.evasion import (CLEARANCE_CAP_M, CLOSING_M, CONTACT_MARGIN_M, band_contact_time,
                                              choose_evasion, contact_times, rollouts, velocity_targets)
from simplebot_navigation.teb.evasion_kernels import rollout_contacts
from simplebot_navigation.teb.feasibility import collision_model
from simplebot_navigation.teb.footprint import FootprintModel

from .scenes import LAB_PADDED_FOOTPRINT, PERIOD, box_cells, lab_planner, rolling_costmap, straight_plan, unicycle_step
from .test_moving_scenes import clearance

ROUND = FootprintModel.circular(0.25)
ROUND_FOOTPRINT = np.zeros((0, 2))       # the costmap check of a round body: its centre cell
LIMITS = (1.0, 0.5, 1.0, 1.0, 1.0)       # max_vel_x, max_vel_x_backwards, max_vel_theta, acc_lim_x, acc_lim_theta


def test_each_target_is_reached_at_the_acceleration_limits_then_held():
    targets = np.array([[1.0, 0.0], [0.0, 1.0], [-0.5, 0.0]])
    poses, times = rollouts(np.zeros(3), (0.0, 0.0), targets, 0.5, 2.0, 3.0)
    assert times[-1] == pytest.approx(3.0) and poses.shape == (3, 31, 3)
    # 0.5 m/s^2 to 1 m/s takes 2 s (1 m), then 1 s at 1 m/s
    assert poses[0, -1, 0] == pytest.approx(2.0, abs=0.06) and poses[0, -1, 1] == pytest.approx(0.0)
    assert poses[1, -1, :2] == pytest.approx([0.0, 0.0]) and poses[1, -1, 2] == pytest.approx(2.75, abs=0.06)
    assert poses[2, -1, 0] == pytest.approx(-1.25, abs=0.06)


def test_the_first_target_is_the_standstill_and_reverse_only_when_allowed():
    targets = velocity_targets(1.0, 0.5, 1.0)
    assert tuple(targets[0]) == (0.0, 0.0) and targets[:, 0].min() == -0.5
    assert velocity_targets(1.0, 0.0, 1.0)[:, 0].min() == 0.0
    assert len(np.unique(targets, axis=0)) == len(targets)


def test_contact_time_of_an_obstacle_closing_in_is_where_the_margin_is_reached():
    # a 0.5 m obstacle 5 m ahead coming at 2 m/s at a standing round robot: gap 4.25 m
    obstacle = np.array([[5.0, 0.0, -2.0, 0.0, 0.5]])
    times = np.arange(31) * 0.1
    poses = np.zeros((1, 31, 3))
    first, nearest = contact_times(ROUND, poses, times, obstacle)
    expected = math.ceil((4.25 - CONTACT_MARGIN_M) / 2.0 / 0.1 - 1e-9) * 0.1
    assert first[0] == pytest.approx(expected)
    assert CONTACT_MARGIN_M - 0.2 <= nearest[0] < CONTACT_MARGIN_M         # the distance at that pose
    first, nearest = contact_times(ROUND, poses, times, obstacle * [1, 1, 0, 0, 1])
    assert first[0] == math.inf and nearest[0] == pytest.approx(4.25)


@pytest.mark.parametrize("prediction", [MotionPrediction(), MotionPrediction(2.0, 0.4, 0.1)],
                         ids=["constant velocity", "uncertain, horizon 2 s"])
@pytest.mark.parametrize("footprint", [footprint_from_radius(0.26), LAB_PADDED_FOOTPRINT], ids=["16-gon", "box"])
def test_the_compiled_contact_check_agrees_with_the_numpy_reference(footprint, prediction):
    rng = np.random.default_rng(3)
    model = collision_model(footprint, 0.25)
    poses, times = rollouts(np.array([0.0, 0.0, 0.3]), (0.4, 0.2), velocity_targets(1.0, 0.5, 1.0), 1.0, 1.0, 5.0)
    obstacles = np.column_stack([rng.uniform(-4, 4, (12, 2)), rng.uniform(-1.5, 1.5, (12, 2)), rng.uniform(0.2, 0.5, 12),
                                 rng.uniform(0.0, 0.1, 12), rng.uniform(0.0, 0.6, 12)])
    obstacles = obstacles[np.hypot(obstacles[:, 0], obstacles[:, 1]) > 1.2]
    if prediction == MotionPrediction():
        obstacles[:, 5:] = 0.0
    first, nearest = rollout_contacts(poses, times, obstacles, model.kernel_model, model.bounding_radius,
                                      CONTACT_MARGIN_M, CLOSING_M, CLEARANCE_CAP_M, *prediction.kernel_arguments)
    ref_first, ref_nearest = contact_times(model, poses, times, obstacles, CONTACT_MARGIN_M, CLEARANCE_CAP_M,
                                           prediction)
    assert np.isfinite(ref_first).any() and np.isinf(ref_first).any()      # both kinds of rollout are compared
    assert first == pytest.approx(ref_first) and nearest == pytest.approx(ref_nearest, abs=1e-9)
    if prediction != MotionPrediction():       # the growth and the horizon change the answer the two agree on
        assert not np.array_equal(ref_first, contact_times(model, poses, times, obstacles[:, :5], CONTACT_MARGIN_M,
                                                           CLEARANCE_CAP_M)[0])


def test_an_obstacle_already_within_the_margin_is_met_only_by_coming_closer():
    beside = np.array([[0.0, 0.8, 0.0, 0.0, 0.5]])                # 0.05 m from the round robot's left side
    times = np.arange(11) * 0.1
    away = np.column_stack([np.zeros(11), -0.1 * np.arange(11), np.zeros(11)])
    closer = np.column_stack([np.zeros(11), 0.013 * np.arange(11), np.zeros(11)])
    first, _ = contact_times(ROUND, np.stack([away, closer]), times, beside)
    assert first[0] == math.inf
    assert first[1] == pytest.approx(0.4)                          # 0.05 m nearer after 4 steps of 1.3 cm


def test_a_band_that_drives_into_where_an_obstacle_will_be_meets_it_and_one_that_waits_does_not():
    crossing = np.array([[2.0, -2.0, 0.0, 1.0, 0.5]])       # crosses the line y = 0 at x = 2 at t = 2 s
    stamps = np.arange(21) * 0.1
    driving = np.column_stack([stamps, np.zeros(21), np.zeros(21)])          # 1 m/s along y = 0
    waiting = np.zeros((21, 3))
    assert band_contact_time(ROUND, driving, stamps, crossing, 2.5) < 2.0
    assert band_contact_time(ROUND, waiting, stamps, crossing, 2.5) == math.inf


def test_a_standing_robot_about_to_be_hit_from_behind_drives_out_of_the_way():
    from_behind = np.array([[-4.0, 0.0, 1.8, 0.0, 0.5]])
    costmap = rolling_costmap(0.0, 0.0, np.zeros((0, 2)), 8.0)
    evasion = choose_evasion(np.zeros(3), (0.0, 0.0), np.array([3.0, 0.0, 0.0]), from_behind, costmap,
                             ROUND_FOOTPRINT, ROUND, LIMITS, 2.5)
    assert evasion.standstill_contact_time < 2.0
    assert evasion.contact_time == math.inf and evasion.omega != 0.0 and evasion.v > 0


def test_an_evasion_never_drives_into_a_wall_sooner_than_the_obstacle_would_arrive():
    # in a corridor 1.2 m wide the only way out of an obstacle from behind is ahead, not aside
    walls = np.vstack([box_cells(0.0, 0.65, 6.0, 0.03), box_cells(0.0, -0.65, 6.0, 0.03)])
    costmap = rolling_costmap(0.0, 0.0, walls, 8.0)
    from_behind = np.array([[-3.0, 0.0, 0.6, 0.0, 0.5]])
    evasion = choose_evasion(np.zeros(3), (0.0, 0.0), np.array([3.0, 0.0, 0.0]), from_behind, costmap,
                             ROUND_FOOTPRINT, ROUND, LIMITS, 2.5)
    assert evasion.contact_time == math.inf
    assert evasion.v >= 0.5 and abs(evasion.omega) < 0.35


#: Three obstacles of 0.4 m at 1.3-1.8 m/s, two crossing the robot's line from its left, one head-on,
#: all meeting the line while the robot drives it
MOVERS = np.array([[7.29, 6.04, -0.64, -1.23, 0.4], [2.04, 6.77, 0.31, -1.22, 0.4], [10.94, -0.31, -1.79, 0.13, 0.4]])


def drive_among(horizon: float):
    """The lab robot's box at 1 m/s from (0, 0) to (8, 0) in the open; closed loop, the obstacles do
    not react. Returns the smallest clearance and the last pose."""
    planner = lab_planner(include_dynamic_obstacles=True, dynamic_obstacle_evasion_horizon=horizon, max_vel_x=1.0,
                          acc_lim_x=1.0, max_vel_theta=1.0, acc_lim_theta=1.0)
    planner.set_plan(straight_plan(0.0, 8.0))
    pose, vel, closest = np.zeros(3), (0.0, 0.0), math.inf
    for k in range(int(20.0 / PERIOD)):
        now = MOVERS.copy()
        now[:, :2] += k * PERIOD * MOVERS[:, 2:4]
        closest = min(closest, clearance(pose, now))
        planner.set_dynamic_obstacles(now)
        result = planner.compute_velocity_commands(pose, vel, rolling_costmap(pose[0], pose[1], np.zeros((0, 2))))
        if result.goal_reached:
            break
        pose, vel = unicycle_step(pose, result.v, result.omega), (result.v, result.omega)
    return closest, pose


def test_a_robot_among_faster_obstacles_gets_out_of_their_way_and_still_arrives():
    closest, pose = drive_among(2.5)
    assert closest > 0.25
    assert np.hypot(pose[0] - 8.0, pose[1]) < 0.2


def test_without_evasion_one_of_them_runs_into_the_robot():
    closest, _ = drive_among(0.0)
    assert closest < 0.0


@pytest.mark.filterwarnings("ignore::RuntimeWarning")     # numpy's overflow notes on 1e308 along the way
def test_hostile_obstacle_rows_leave_the_evasion_finite():
    planner = lab_planner(include_dynamic_obstacles=True, max_vel_x=1.0, acc_lim_x=1.0, max_vel_theta=1.0,
                          acc_lim_theta=1.0)
    planner.set_plan(straight_plan(0.0, 8.0))
    hostile = np.array([[1e308, -1e308, 1e308, 1e308, 1e308], [0.9, 0.0, -1e308, 0.0, 0.2],
                        [2.0, 0.0, -1.5, 0.0, 0.4], [-1e-300, 1e-300, 0.0, 0.0, 0.0]])
    planner.set_dynamic_obstacles(hostile)
    result = planner.compute_velocity_commands(np.zeros(3), (0.5, 0.0), rolling_costmap(0.0, 0.0, np.zeros((0, 2))))
    assert math.isfinite(result.v) and math.isfinite(result.omega)
    evasion = choose_evasion(np.zeros(3), (0.5, 0.0), np.array([3.0, 0.0, 0.0]), hostile,
                             rolling_costmap(0.0, 0.0, np.zeros((0, 2))), ROUND_FOOTPRINT, ROUND, LIMITS, 2.5)
    assert math.isfinite(evasion.v) and math.isfinite(evasion.omega)
