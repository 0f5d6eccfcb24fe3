"""Closed loop among moving obstacles: what a user of the planner notices."""

import math

import numpy as np
import pytest

from simplebot_navigation.perception.prediction import MotionPrediction

from .scenes import PERIOD, box_cells, lab_planner, rolling_costmap, straight_plan, unicycle_step

#: a 4 m wide corridor along x
WALLS = np.vstack([box_cells(4.0, 2.0, 6.0, 0.03), box_cells(4.0, -2.0, 6.0, 0.03)])
#: a person (0.3 m) crossing the corridor upwards at 0.4 m/s, on the robot's line at t = 4.5 s
CROSSING = np.array([[2.2, -1.8, 0.0, 0.4, 0.3]])
#: ... and one walking towards the robot at 0.5 m/s, 0.1 m left of its line
ONCOMING = np.array([[7.0, 0.1, -0.5, 0.0, 0.3]])


def drive_among(planner, movers: np.ndarray, seconds: float):
    """Closed loop with the movers at constant velocity (gone once out of the corridor); the
    costmap holds only the walls, as the tracker removes the movers' marks. Per cycle:
    (time, pose, result, movers given, band poses, band time stamps)."""
    pose, vel, cycles = np.zeros(3), (0.0, 0.0), []
    for k in range(int(round(seconds / PERIOD))):
        now = movers.copy()
        now[:, :2] += k * PERIOD * movers[:, 2:4]
        now = now[np.abs(now[:, 1]) < 2.3]
        planner.set_dynamic_obstacles(now)
        result = planner.compute_velocity_commands(pose, vel, rolling_costmap(pose[0], pose[1], WALLS))
        cycles.append((k * PERIOD, pose, result, now, planner.band_poses, planner.band_time_stamps))
        if result.goal_reached:
            break
        pose, vel = unicycle_step(pose, result.v, result.omega), (result.v, result.omega)
    return cycles


def clearance(pose, movers: np.ndarray) -> float:
    """Distance from the lab robot's box (0.9 x 0.6 m) to the nearest mover's circle."""
    if len(movers) == 0:
        return math.inf
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rel = movers[:, :2] - pose[:2]
    along, across = c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]
    out = np.hypot(np.maximum(np.abs(along) - 0.45, 0.0), np.maximum(np.abs(across) - 0.3, 0.0))
    return float(np.min(out - movers[:, 4]))


@pytest.fixture(scope="module")
def crossing_runs():
    runs = {}
    for predict in (True, False):
        planner = lab_planner(include_dynamic_obstacles=predict)
        planner.set_plan(straight_plan(0.0, 5.0))
        runs[predict] = (planner, drive_among(planner, CROSSING, 40.0))
    return runs


def test_a_robot_yields_to_a_person_crossing_its_path_and_passes_behind(crossing_runs):
    planner, cycles = crossing_runs[True]
    assert cycles[-1][2].goal_reached and all(c[2].ok for c in cycles)
    assert min(clearance(pose, now) for _, pose, _, now, _, _ in cycles) > 0.25
    when = next(c for c in cycles if c[0] >= 4.5)                 # the person crosses the robot's line
    assert when[1][0] < 2.2 - 0.3 - 0.45 - 0.2                     # the robot is still behind the person's track
    # and no band of the way plans through where the person will be within the next two seconds
    for _, pose, _, now, poses, stamps in cycles:
        if len(now):
            gap = planner.model.pair_distances(poses, MotionPrediction().centres(now, stamps)[0]) - now[0, 4]
            assert gap[stamps <= 2.0].min() > 0.25


def test_without_prediction_the_same_person_is_avoided_where_it_stands_only(crossing_runs):
    (_, predicted), (_, standing) = crossing_runs[True], crossing_runs[False]
    closest = {run: min(clearance(pose, now) for _, pose, _, now, _, _ in cycles)
               for run, cycles in (("predicted", predicted), ("standing", standing))}
    assert closest["standing"] < closest["predicted"] - 0.1
    at = {run: next(c[1] for c in cycles if c[0] >= 4.0) for run, cycles in (("p", predicted), ("s", standing))}
    assert np.hypot(*(at["p"][:2] - at["s"][:2])) > 0.2           # different ways by the time the person crosses


def test_an_oncoming_person_makes_the_robot_swerve():
    planner = lab_planner(include_dynamic_obstacles=True)
    planner.set_plan(straight_plan(0.0, 8.0))
    cycles = drive_among(planner, ONCOMING, 40.0)
    assert cycles[-1][2].goal_reached and all(c[2].ok for c in cycles)
    assert min(clearance(pose, now) for _, pose, _, now, _, _ in cycles) > 0.25
    passing = [pose for _, pose, _, now, _, _ in cycles if len(now) and abs(pose[0] - now[0, 0]) < 0.5]
    assert passing and min(abs(pose[1] - ONCOMING[0, 1]) for pose in passing) > 0.3 + 0.3 + 0.2
