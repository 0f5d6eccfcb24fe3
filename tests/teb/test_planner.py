import math

import numpy as np
import pytest

from simplebot_navigation.teb import planner as planner_module
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.optimizer import RotType
from simplebot_navigation.teb.planner import TebLocalPlanner

from .scenes import (LAB_FOOTPRINT, LAB_PADDED_FOOTPRINT, LAB_PARAMS, PERIOD, RES, box_cells, footprint_hits, lab_door_scene,
                     lab_planner,
                     rolling_costmap, straight_plan, unicycle_step)


def drive(planner: TebLocalPlanner, goal_x: float, obstacles: np.ndarray, seconds: float, pose=None):
    """Closed loop: plan, command, integrate a unicycle. Returns (poses, commands, results)."""
    pose = np.zeros(3) if pose is None else np.asarray(pose, dtype=float)
    vel = (0.0, 0.0)
    poses, commands, results = [pose], [], []
    for _ in range(int(seconds / PERIOD)):
        result = planner.compute_velocity_commands(pose, vel, rolling_costmap(pose[0], pose[1], obstacles))
        results.append(result)
        if result.goal_reached:
            break
        commands.append((result.v, result.omega, vel))
        pose = unicycle_step(pose, result.v, result.omega)
        vel = (result.v, result.omega)
        poses.append(pose)
    return np.array(poses), commands, results


def test_closed_loop_reaches_a_goal_3m_away_past_an_obstacle():
    planner = lab_planner(enable_homotopy_class_planning=False)
    planner.set_plan(straight_plan(0.0, 3.0))
    obstacle = box_cells(1.6, 0.25, 0.15, 0.15)           # a 0.3 m box just left of the plan
    poses, commands, results = drive(planner, 3.0, obstacle, seconds=30.0)
    assert results[-1].goal_reached, results[-1].message
    assert math.hypot(poses[-1][0] - 3.0, poses[-1][1]) < planner.cfg.goal_tolerance.xy_goal_tolerance
    assert abs(poses[-1][2]) < planner.cfg.goal_tolerance.yaw_goal_tolerance
    assert not any(footprint_hits(p, LAB_FOOTPRINT, obstacle) for p in poses)
    assert all(r.ok for r in results)
    # it went around: on the right of the box, the lab robot's half width plus a margin away
    near = poses[np.abs(poses[:, 0] - 1.6) < 0.2]
    assert near[:, 1].max() < 0.25 - 0.15 - 0.3


def test_commands_never_exceed_the_velocity_limits():
    planner = lab_planner(enable_homotopy_class_planning=False)
    cfg = planner.cfg
    planner.set_plan(np.column_stack([np.linspace(0, 3, 61), np.linspace(0, 1.5, 61), np.zeros(61)]))
    _, commands, _ = drive(planner, 3.0, box_cells(1.2, 0.9, 0.1, 0.1), seconds=6.0)
    for v, omega, (v_cur, omega_cur) in commands:
        assert -cfg.robot.max_vel_x_backwards - 1e-12 <= v <= cfg.robot.max_vel_x + 1e-12
        assert abs(omega) <= cfg.robot.max_vel_theta + 1e-12
        assert abs(v - v_cur) <= cfg.robot.acc_lim_x * PERIOD + 1e-12
        assert abs(omega - omega_cur) <= cfg.robot.acc_lim_theta * PERIOD + 1e-12
    assert max(c[0] for c in commands) == pytest.approx(cfg.robot.max_vel_x)


def test_velocity_limits_win_over_the_acceleration_window():
    planner = lab_planner(enable_homotopy_class_planning=False)
    planner.set_plan(straight_plan(0.0, 3.0))
    result = planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.9, 0.8), rolling_costmap(0, 0, np.zeros((0, 2))))
    assert result.ok
    assert result.v == pytest.approx(planner.cfg.robot.max_vel_x)
    assert result.omega == pytest.approx(planner.cfg.robot.max_vel_theta)


def test_a_live_change_reaches_its_section_and_restart_only_parameters_stay():
    planner = lab_planner(enable_homotopy_class_planning=False)
    planner.set_plan(straight_plan(0.0, 3.0))
    planner.reconfigure(TebConfig.from_params({**LAB_PARAMS, "enable_homotopy_class_planning": False,
                                               "max_vel_x": 0.25, "max_vel_theta": 0.2, "odom_topic": "/elsewhere"}))
    result = planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.9, 0.8), rolling_costmap(0, 0, np.zeros((0, 2))))
    assert (result.v, result.omega) == (pytest.approx(0.25), pytest.approx(0.2))
    assert planner.cfg.odom_topic == "/odom"


def test_first_command_from_rest_is_limited_by_acceleration_over_one_period():
    planner = lab_planner(enable_homotopy_class_planning=False)
    planner.set_plan(straight_plan(0.0, 3.0))
    result = planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
    assert result.v == pytest.approx(planner.cfg.robot.acc_lim_x * PERIOD)
    assert result.omega == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("pose, velocity, free_goal_vel, reached", [
    ((2.9, 0.05, 0.05), (0.0, 0.0), False, True),
    ((2.9, 0.05, 0.05), (0.2, 0.0), False, False),           # still moving
    ((2.9, 0.05, 0.05), (0.2, 0.0), True, True),             # ... unless free_goal_vel
    ((2.9, 0.05, 0.05), (0.0, 0.15), False, False),          # still turning
    ((2.75, 0.0, 0.0), (0.0, 0.0), False, False),            # 0.25 m away > xy_goal_tolerance 0.2
    ((3.0, 0.0, 0.12), (0.0, 0.0), False, False),            # yaw off by more than 0.1
    ((3.0, 0.0, 0.08), (0.09, 0.09), False, True),           # below the stop velocities
])
def test_goal_reached_logic(pose, velocity, free_goal_vel, reached):
    planner = lab_planner(free_goal_vel=free_goal_vel)
    planner.set_plan(straight_plan(0.0, 3.0))
    assert planner.is_goal_reached(pose, velocity) is reached
    result = planner.compute_velocity_commands(pose, velocity, rolling_costmap(pose[0], pose[1], np.zeros((0, 2))))
    assert result.goal_reached is reached
    if reached:
        assert (result.v, result.omega, result.ok) == (0.0, 0.0, True)


@pytest.mark.parametrize("homotopy", [False, True])
def test_wall_across_the_path_is_reported_infeasible_and_the_planner_reset(homotopy):
    # The optimiser cannot route around a wall spanning the costmap: the band piles up before it
    # and jumps across; the check (with interpolation) must see the jump within the poses it covers.
    planner = lab_planner(enable_homotopy_class_planning=homotopy, feasibility_check_no_poses=15)
    planner.set_plan(straight_plan(0.0, 3.0))
    wall = np.column_stack([np.full(81, 1.0), np.linspace(-2, 2, 81)])
    result = planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.2, 0.0), rolling_costmap(0, 0, wall))
    assert not result.ok
    assert result.message == "trajectory is not feasible. Resetting planner..."
    assert (result.v, result.omega) == (0.0, 0.0)
    assert len(planner.band_poses) == 0 and planner.candidate_bands == []


@pytest.mark.parametrize("shrink", [True, False])
def test_after_an_infeasible_band_the_horizon_is_halved_for_shrink_horizon_min_duration(shrink):
    planner = lab_planner(shrink_horizon_backup=shrink, shrink_horizon_min_duration=10.0)
    planner.set_plan(straight_plan(-3.0, 8.0))
    free = rolling_costmap(0, 0, np.zeros((0, 2)), size_m=10.0)
    touching = rolling_costmap(0, 0, np.array([[LAB_PADDED_FOOTPRINT[0, 0], 0.0]]), size_m=10.0)  # on the outline
    assert not planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), touching).ok
    local_goals = []
    for _ in range(int(12.0 / PERIOD)):
        assert planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), free).ok
        local_goals.append(planner.transformed_plan[-1, 0])
    full = 3.0  # max_global_plan_lookahead_dist on the plan that starts 0.95 m behind the robot
    if not shrink:
        assert local_goals == pytest.approx([full] * len(local_goals))
        return
    # TEB's reduction: half the local goal's index in the pruned plan, (3.0 + 0.95) / 0.05 // 2 poses
    shortened = full - (79 // 2) * RES
    assert local_goals[:int(9.5 / PERIOD)] == pytest.approx([shortened] * int(9.5 / PERIOD))
    assert local_goals[int(10.5 / PERIOD):] == pytest.approx([full] * (len(local_goals) - int(10.5 / PERIOD)))


def test_plan_is_pruned_behind_and_cut_at_the_lookahead():
    planner = lab_planner()
    planner.set_plan(straight_plan(-3.0, 8.0))
    # a 10 m costmap, so that max_global_plan_lookahead_dist (3 m) rather than the map limits
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0),
                                      rolling_costmap(0, 0, np.zeros((0, 2)), size_m=10.0))
    # poses more than global_plan_prune_distance (1 m) behind the robot are dropped
    assert planner.global_plan[0, 0] == pytest.approx(-0.95)
    plan = planner.transformed_plan
    np.testing.assert_allclose(plan[0], [0.0, 0.0, 0.0])
    # TEB counts the plan segment leading into the closest pose as well: the pose at 2.95 m has
    # 3.0 m behind it, so the pose after it (3.0 m) is the last one taken
    assert plan[-1, 0] == pytest.approx(3.0)
    np.testing.assert_allclose(planner.band_poses[-1], plan[-1])


def test_local_plan_stays_inside_85_percent_of_the_costmap():
    planner = lab_planner(max_global_plan_lookahead_dist=10.0)
    planner.set_plan(straight_plan(0.0, 8.0))
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
    # half of 5 m times 0.85: the last pose added is the first one beyond 2.125 m
    assert planner.transformed_plan[-1, 0] == pytest.approx(2.15)


def test_new_far_goal_reinitialises_the_band():
    planner = lab_planner(enable_homotopy_class_planning=False)
    empty = rolling_costmap(0, 0, np.zeros((0, 2)))
    planner.set_plan(straight_plan(0.0, 2.0))
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), empty)
    planner.set_plan(np.column_stack([np.zeros(41), np.linspace(0, -2, 41), np.full(41, -math.pi / 2)]))
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), empty)
    np.testing.assert_allclose(planner.band_poses[-1], [0.0, -2.0, -math.pi / 2], atol=1e-9)
    assert planner.band_poses[:, 0].max() < 0.3


def test_homotopy_classes_get_the_robot_around_a_barrier_that_traps_a_single_band():
    # a 2 m wall straight across the plan, 0.9 m ahead: one band stays pinned to the plan's side
    # and keeps failing the feasibility check; the homotopy planner seeds bands around either end
    barrier = box_cells(1.5, 0.0, 0.05, 1.0)
    start = (0.6, 0.0, 0.0)
    single = lab_planner(enable_homotopy_class_planning=False)
    single.set_plan(straight_plan(0.6, 3.5))
    poses, _, results = drive(single, 3.5, barrier, seconds=3.0, pose=start)
    assert not results[-1].goal_reached
    assert np.abs(poses[:, 1]).max() < 0.5                   # never heads for either end
    assert any(r.message == "trajectory is not feasible. Resetting planner..." for r in results)

    planner = lab_planner(enable_homotopy_class_planning=True)
    planner.set_plan(straight_plan(0.6, 3.5))
    poses, _, results = drive(planner, 3.5, barrier, seconds=30.0, pose=start)
    assert results[-1].goal_reached
    assert not any(footprint_hits(p, LAB_FOOTPRINT, barrier) for p in poses)
    assert np.abs(poses[:, 1]).max() > 1.0 + 0.3             # around the end of the wall


def test_homotopy_off_keeps_a_single_band():
    planner = lab_planner(enable_homotopy_class_planning=False)
    planner.set_plan(straight_plan(0.0, 3.0))
    obstacle = box_cells(1.5, 0.0, 0.2, 0.2)
    for _ in range(3):
        planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, obstacle))
        assert len(planner.candidate_bands) == 1


def test_visualisation_accessors():
    planner = lab_planner()
    planner.set_plan(straight_plan(0.0, 3.0))
    obstacle = box_cells(1.5, 1.0, 0.1, 0.1)
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, obstacle))
    poses, stamps = planner.band_poses, planner.band_time_stamps
    assert poses.shape[1] == 3 and len(stamps) == len(poses) and stamps[0] == 0.0
    assert np.all(np.diff(stamps) > 0)
    assert len(planner.footprint_outlines()) == len(poses)
    assert len(planner.obstacles) == len(obstacle)
    assert planner.warnings == []


def test_obstacles_behind_the_robot_are_skipped_beyond_the_configured_distance():
    planner = lab_planner()
    planner.set_plan(straight_plan(0.0, 3.0))
    behind = np.array([[-1.0, 0.0], [-2.0, 0.0], [1.0, 2.0]])
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, behind))
    np.testing.assert_allclose(np.sort(planner.obstacles[:, 0]), [-0.975, 1.025])


def test_bad_inputs():
    planner = lab_planner()
    result = planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
    assert not result.ok and result.message == "no global plan set"
    with pytest.raises(ValueError, match="global plan"):
        planner.set_plan(np.zeros((5, 2)))
    with pytest.raises(ValueError, match="controller_period"):
        TebLocalPlanner(planner.cfg, LAB_PADDED_FOOTPRINT, 0.0)


def test_small_model_warns_against_the_costmap_footprint():
    planner = lab_planner(min_obstacle_dist=0.05)
    assert any("inscribed radius" in w for w in planner.warnings)


def test_unsupported_features_are_reported_once_each():
    planner = lab_planner(min_turning_radius=0.5, exact_arc_length=True)
    assert sum("has no effect" in w for w in planner.warnings) == 2
    assert sum("TebLocalPlannerROS/min_turning_radius" in w for w in planner.warnings) == 1
    assert sum("TebLocalPlannerROS/exact_arc_length" in w for w in planner.warnings) == 1



def test_lab_robot_turns_through_a_door_narrower_than_min_obstacle_dist_asks_for():
    # The lab's corridor (walls at y = +-1.25) with a 1.2 m door at x = 1.5: on the door's centre
    # line the two_circles model keeps 0.625 - 0.2 = 0.425 m from the jamb cells, less than
    # min_obstacle_dist 0.5. The band must still take the robot through on the centre line
    # instead of stalling in front of the door with its poses pushed out of it.
    walls, plan = lab_door_scene()
    planner = lab_planner()
    planner.set_plan(plan)
    poses, _, results = drive(planner, 0.0, walls, seconds=25.0)
    assert results[-1].goal_reached, (results[-1].message, poses[-1])
    assert not any(footprint_hits(p, LAB_FOOTPRINT, walls) for p in poses)
    in_door = poses[np.abs(poses[:, 1] - 1.25) < 0.3]
    assert np.abs(in_door[:, 0] - 1.5).max() < 0.1                # on the centre line


def test_an_exhausted_cycle_budget_postpones_the_alternatives_and_is_reported_once():
    # a controller period so short that every cycle's budget is spent before the alternatives
    barrier = box_cells(1.5, 0.0, 0.05, 1.0)
    planner = TebLocalPlanner(lab_planner().cfg, LAB_PADDED_FOOTPRINT, 1e-9)
    planner.set_plan(straight_plan(0.6, 3.5))
    pose, notices = np.array([0.6, 0.0, 0.0]), []
    for _ in range(5):
        result = planner.compute_velocity_commands(pose, (0.0, 0.0), rolling_costmap(pose[0], pose[1], barrier))
        notices += planner.pop_notices()
        assert result.ok and planner.planner.bands_optimized == 1
    # the seeds explored around the wall were never optimised: each was dropped, the followed band kept
    assert len(planner.candidate_bands) == 1
    assert len(notices) == 1 and notices[0][0] == "warn" and "postponed" in notices[0][1]
    assert planner.pop_notices() == []


def test_a_budget_that_suffices_changes_nothing(monkeypatch):
    barrier = box_cells(1.5, 0.0, 0.05, 1.0)
    runs = []
    for fraction in (planner_module.CYCLE_BUDGET_FRACTION, 1e9):
        monkeypatch.setattr(planner_module, "CYCLE_BUDGET_FRACTION", fraction)
        planner = lab_planner()
        planner.set_plan(straight_plan(0.6, 3.5))
        poses, _, _ = drive(planner, 3.5, barrier, seconds=3.0, pose=(0.6, 0.0, 0.0))
        assert planner.pop_notices() == []
        runs.append(poses)
    np.testing.assert_array_equal(runs[0], runs[1])


def rock(planner, omegas):
    """Cycles at the origin with the odometry turn rates given; with tiny acceleration limits each
    command stays within 0.001 of the odometry, so the commands rock as the robot does."""
    free = rolling_costmap(0, 0, np.zeros((0, 2)), size_m=10.0)
    states = []
    for omega in omegas:
        planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, omega), free)
        states.append((planner.failure_detector.oscillating, planner.preferred_rotdir))
    return states


ROCKING = dict(acc_lim_x=0.01, acc_lim_theta=0.01, oscillation_filter_duration=2.0,
               oscillation_recovery_min_duration=3.0)


@pytest.mark.parametrize("phase, expected", [(0, RotType.right), (1, RotType.left)])
def test_oscillating_commands_make_the_optimiser_prefer_the_measured_turning_direction(phase, expected):
    planner = lab_planner(**ROCKING)
    planner.set_plan(straight_plan(0.0, 3.0))
    # 2 s window at 10 Hz: detection from the 10th command on (the first is the zero command
    # before any was sent, as in TEB)
    states = rock(planner, [0.02 * (-1) ** (k + phase) for k in range(30)])
    first = [oscillating for oscillating, _ in states].index(True)
    assert first == 9
    # the direction the robot turned in at detection, kept while the rocking goes on
    assert 0.02 * (-1) ** (first + phase) * expected > 0
    assert [rotdir for _, rotdir in states[first:]] == [expected] * (len(states) - first)
    assert planner.planner.optimizer.prefer_rotdir == expected
    notices = planner.pop_notices()
    assert notices == [("warn", "TEB: possible oscillation (of the robot or its local plan) detected; "
                                f"preferring to turn {expected.name} for 3 s")]
    # the robot keeps still: once the rocking has left the window, 3 s later the preference expires
    states = rock(planner, [0.0] * 80)
    last = max(k for k, (oscillating, _) in enumerate(states) if oscillating)
    kept = [rotdir for _, rotdir in states]
    assert kept[:last + 30] == [expected] * (last + 30)
    assert kept[last + 30:] == [RotType.none] * (80 - last - 30)
    assert planner.planner.optimizer.prefer_rotdir == RotType.none
    assert planner.pop_notices() == [("info", "TEB: oscillation recovery expired")]


def test_no_preference_without_oscillation_recovery_and_none_after_a_reset():
    planner = lab_planner(**ROCKING, oscillation_recovery=False)
    planner.set_plan(straight_plan(0.0, 3.0))
    assert {rotdir for _, rotdir in rock(planner, [0.02 * (-1) ** k for k in range(30)])} == {RotType.none}
    planner = lab_planner(**ROCKING)
    planner.set_plan(straight_plan(0.0, 3.0))
    assert rock(planner, [0.02 * (-1) ** k for k in range(12)])[-1][1] != RotType.none
    planner.reset()
    assert planner.preferred_rotdir == planner.planner.optimizer.prefer_rotdir == RotType.none
    # the old commands are gone too: detection needs half a window of new ones
    assert [oscillating for oscillating, _ in rock(planner, [0.02 * (-1) ** k for k in range(11)])] == \
        [False] * 9 + [True] * 2
    # switched off while it holds a preference: the preference goes with it
    planner.reconfigure(TebConfig.from_params({**LAB_PARAMS, **ROCKING, "oscillation_recovery": False}))
    planner.pop_notices()
    assert rock(planner, [0.02])[-1][1] == planner.planner.optimizer.prefer_rotdir == RotType.none
    assert planner.pop_notices() == [("info", "TEB: oscillation recovery disabled")]


def test_a_live_filter_duration_resizes_the_detector_window():
    planner = lab_planner(**ROCKING)
    planner.set_plan(straight_plan(0.0, 3.0))
    planner.reconfigure(TebConfig.from_params({**LAB_PARAMS, **ROCKING, "oscillation_filter_duration": 1.0}))
    assert [oscillating for oscillating, _ in rock(planner, [0.02 * (-1) ** k for k in range(6)])] == \
        [False] * 4 + [True] * 2
    # 1 s is now 5 commands: half full after 2, but two sign changes take 3
    planner.set_controller_period(2 * PERIOD)
    planner.reset()
    assert [oscillating for oscillating, _ in rock(planner, [0.02 * (-1) ** k for k in range(4)])] == \
        [False] * 2 + [True] * 2


def test_a_plan_that_repeats_a_pose_turns_the_robot_on_the_spot():
    """A plan whose first poses coincide (start and goal in one cell) must not give the band a zero dT."""
    planner = lab_planner()
    planner.set_plan(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.5]]))
    pose, vel = np.zeros(3), (0.0, 0.0)
    for _ in range(100):
        result = planner.compute_velocity_commands(pose, vel, rolling_costmap(0.0, 0.0, np.zeros((0, 2))))
        if result.goal_reached:
            break
        pose, vel = unicycle_step(pose, result.v, result.omega), (result.v, result.omega)
    assert result.goal_reached and abs(pose[2] - 1.5) < 0.1 and np.hypot(*pose[:2]) < 0.05
