"""Uncertain moving obstacles in TEB: the covariance the tracker gives widens each obstacle's keep-out circle with
the time ahead (perception/prediction.py), in the edges, the feasibility check and the evasion."""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.footprint import footprint_radii
from simplebot_navigation.perception.prediction import MotionPrediction
from simplebot_navigation.teb import planner as planner_module
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.feasibility import collision_model, is_trajectory_feasible
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.obstacles import motion_prediction, planned_motion
from simplebot_navigation.teb.optimizer import TebOptimizer

from .scenes import LAB_PADDED_FOOTPRINT, PERIOD, lab_planner, rolling_costmap, straight_plan, unicycle_step
from .test_dynamic_obstacles import straight_band
from .test_moving_scenes import CROSSING, WALLS, clearance


@pytest.fixture(autouse=True)
def unlimited_cycle_budget(monkeypatch):
    """A loaded machine must not postpone an alternative band in one run of a comparison and not the other."""
    monkeypatch.setattr(planner_module, "CYCLE_BUDGET_FRACTION", 1e9)


def covariance(count: int, position_sigma: float = 0.03, velocity_sigma: float = 0.2) -> np.ndarray:
    return np.tile(np.diag([position_sigma ** 2] * 2 + [velocity_sigma ** 2] * 2), (count, 1, 1))


def crossing_loop(seconds: float, covariance_of=None, **params) -> list[tuple]:
    """test_moving_scenes' person crossing the corridor, the robot driving 5 m; per cycle the command, ok, the
    band and the robot's clearance from the person. covariance_of(count): the covariances given (None: none)."""
    planner = lab_planner(include_dynamic_obstacles=True, **params)
    planner.set_plan(straight_plan(0.0, 5.0))
    pose, vel, cycles = np.zeros(3), (0.0, 0.0), []
    for k in range(int(round(seconds / PERIOD))):
        now = CROSSING.copy()
        now[:, :2] += k * PERIOD * CROSSING[:, 2:4]
        now = now[np.abs(now[:, 1]) < 2.3]
        planner.set_dynamic_obstacles(now, None if covariance_of is None else covariance_of(len(now)))
        result = planner.compute_velocity_commands(pose, vel, rolling_costmap(pose[0], pose[1], WALLS))
        cycles.append((result.v, result.omega, result.ok, result.goal_reached, planner.band_poses,
                       planner.band_time_stamps, clearance(pose, now)))
        if result.goal_reached:
            break
        pose, vel = unicycle_step(pose, result.v, result.omega), (result.v, result.omega)
    return cycles


# -- the planner's input ---------------------------------------------------------------------------
def test_covariances_are_validated_and_the_bad_rows_reported_once():
    planner = lab_planner(include_dynamic_obstacles=True)
    planner.set_plan(straight_plan(0.0, 3.0))
    rows = np.array([[2.0, 1.0, 0.0, -0.2, 0.3], [3.0, -1.0, 0.5, 0.0, 0.3], [4.0, 0.0, 0.0, 0.0, 0.3]])
    with pytest.raises(ValueError, match=r"\(K, 4, 4\).*3 obstacles; got shape \(2, 4, 4\)"):
        planner.set_dynamic_obstacles(rows, covariance(2))
    with pytest.raises(ValueError, match=r"got shape \(3, 2, 2\)"):
        planner.set_dynamic_obstacles(rows, np.zeros((3, 2, 2)))
    bad = covariance(3)
    bad[1, 2, 2] = -0.04                                     # a negative variance
    bad[2, 0, 0] = np.inf
    for _ in range(2):
        planner.set_dynamic_obstacles(rows, bad)
    notices = planner.pop_notices()
    assert len(notices) == 1 and "dropped 2 of 3 dynamic obstacles" in notices[0][1]
    assert "covariance" in notices[0][1]
    planner.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0), rolling_costmap(0, 0, np.zeros((0, 2))))
    np.testing.assert_array_equal(planner.dynamic_obstacles, rows[:1])
    planner.set_dynamic_obstacles(np.zeros((0, 5)), np.zeros((0, 4, 4)))
    planner.set_dynamic_obstacles(rows, np.zeros((3, 4, 4)))          # a publisher without covariances
    assert planner.pop_notices() == []


# -- where the growth is used ------------------------------------------------------------------------
def test_the_edges_keep_out_of_the_grown_circle_which_stops_growing_at_the_horizon():
    cfg = TebConfig.from_params({"include_dynamic_obstacles": True, "dynamic_obstacle_prediction_horizon": 3.0,
                                 "dynamic_obstacle_max_uncertainty": 0.3})
    band = straight_band(cfg, length=4.0)
    tracked = np.array([[2.0, -1.0, 0.0, 0.3, 0.25]])
    rows = planned_motion(tracked, True, covariance(1), cfg.moving_obstacles.dynamic_obstacle_uncertainty_sigmas)
    edges = TebOptimizer(cfg, FootprintModel.point()).build_edges(band, None, None, 50.0, rows, 50.0)
    times = band.time_stamps[edges.dyn_pose]
    assert times.max() > 3.5                                          # poses beyond the horizon have edges
    np.testing.assert_allclose(edges.dyn_obstacle[:, 1], -1.0 + 0.3 * times)    # it walks on beyond it
    spread = cfg.moving_obstacles.dynamic_obstacle_uncertainty_sigmas * np.hypot(0.03, 0.2 * np.minimum(times, 3.0))
    np.testing.assert_allclose(edges.dyn_obstacle[:, 2], 0.25 + np.minimum(spread, 0.3))
    assert edges.dyn_obstacle[:, 2].max() > 0.25 + 0.29


def test_a_band_that_passes_close_to_an_uncertain_obstacle_is_infeasible():
    costmap = rolling_costmap(0, 0, np.zeros((0, 2)))
    inscribed = footprint_radii(LAB_PADDED_FOOTPRINT)[0]
    poses = np.column_stack([np.linspace(0.0, 2.0, 11), np.zeros(11), np.zeros(11)])
    stamps = np.linspace(0.0, 2.5, 11)
    standing = np.array([[1.0, 0.71, 0.0, 0.0, 0.3]])                    # 0.08 m beside the band's box
    cfg = TebConfig.from_params({"include_dynamic_obstacles": True})

    def feasible(cov):
        rows = planned_motion(standing, True, cov, cfg.moving_obstacles.dynamic_obstacle_uncertainty_sigmas)
        return is_trajectory_feasible(costmap, LAB_PADDED_FOOTPRINT, inscribed, poses, 10, -1.0, math.pi, stamps,
                                      rows, collision_model(LAB_PADDED_FOOTPRINT, inscribed), motion_prediction(cfg))

    assert feasible(None) and feasible(np.zeros((1, 4, 4)))
    assert not feasible(covariance(1))


# -- no uncertainty: nothing changes -------------------------------------------------------------------
@pytest.mark.parametrize("params, covariance_of", [
    ({}, lambda count: np.zeros((count, 4, 4))),
    ({"dynamic_obstacle_uncertainty_sigmas": 0.0}, covariance),
    ({"dynamic_obstacle_prediction_horizon": 0.0}, lambda count: np.zeros((count, 4, 4))),
], ids=["zero covariance", "zero sigmas", "zero covariance, no horizon"])
def test_without_uncertainty_the_closed_loop_is_bit_identical_to_no_covariance(params, covariance_of):
    plain = crossing_loop(12.0, None, **params)
    given = crossing_loop(12.0, covariance_of, **params)
    assert any(v > 0.05 for v, *_ in plain), "the robot never drove: the comparison proves nothing"
    assert len(plain) == len(given)
    for cycle, (a, b) in enumerate(zip(plain, given)):
        assert a[:4] == b[:4], f"cycle {cycle}: command {a[:4]} against {b[:4]}"
        assert np.array_equal(a[4], b[4]) and np.array_equal(a[5], b[5]), f"cycle {cycle}: the bands differ"


def test_the_prediction_follows_the_configuration():
    cfg = TebConfig.from_params({"include_dynamic_obstacles": True, "dynamic_obstacle_prediction_horizon": 2.0})
    assert motion_prediction(cfg) == MotionPrediction(2.0, cfg.moving_obstacles.dynamic_obstacle_max_uncertainty,
                                                      cfg.moving_obstacles.dynamic_obstacle_radius_growth)
    assert motion_prediction(TebConfig.from_params({"include_dynamic_obstacles": False})) == MotionPrediction()
    assert motion_prediction(TebConfig.from_params({"include_dynamic_obstacles": True,
                                                    "dynamic_obstacle_prediction_horizon": 0.0})).horizon == math.inf


# -- the closed loop -----------------------------------------------------------------------------------
def test_an_uncertain_person_crossing_is_given_more_room():
    certain = crossing_loop(40.0, None)
    uncertain = crossing_loop(40.0, covariance)
    for run in (certain, uncertain):
        assert run[-1][3] and all(c[2] for c in run)                      # arrived, every cycle valid
    closest = {name: min(c[6] for c in run) for name, run in (("certain", certain), ("uncertain", uncertain))}
    assert closest["uncertain"] > closest["certain"] + 0.1
    assert len(uncertain) < 1.2 * len(certain)                            # at little cost in time
