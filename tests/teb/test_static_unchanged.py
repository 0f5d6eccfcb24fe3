"""Without a moving obstacle nearby, modelling moving obstacles leaves TEB's static behaviour alone: closed-loop
runs give the same bands and commands, cycle by cycle and bit for bit. (TEB's band resize repeats until nothing
changes when it predicts moving obstacles; here only while one is near the band, teb/optimizer.py.)

Each pair of runs is made in this process, so both share one code generation: bit identity is a fair claim here,
where a recording made on another CPU would not be (numba compiles for the host's CPU). The cycle budget is
lifted, so the wall clock of a loaded machine cannot postpone an alternative band in one run and not the other.
"""

import numpy as np
import pytest

from simplebot_navigation.teb import planner as planner_module
from tests.teb.scenes import box_cells, lab_door_scene, lab_planner, rolling_costmap, straight_plan, unicycle_step

CYCLES = 40
#: a moving obstacle far outside the local costmap, walking away from the robot: (x, y, vx, vy, radius) relative
#: to the robot's position at each cycle
FAR_AWAY = np.array([[40.0, 30.0, 0.8, 0.6, 0.3]])


def _door():
    walls, plan = lab_door_scene()
    return walls, plan, (0.0, 0.0, 0.0)


SCENES = {
    "box": lambda: (box_cells(1.6, 0.25, 0.15, 0.15), straight_plan(0.0, 3.0), (0.0, 0.0, 0.0)),
    "barrier": lambda: (box_cells(1.5, 0.0, 0.05, 1.0), straight_plan(0.6, 3.5), (0.6, 0.0, 0.0)),
    "door": _door,
}


def closed_loop(scene: str, homotopy: bool, dynamic: bool, moving: np.ndarray | None = None) -> list[tuple]:
    """One entry per cycle: the command, ok, and every candidate band's poses and time differences. moving: rows
    given to set_dynamic_obstacles every cycle, positions relative to the robot."""
    obstacles, plan, start = SCENES[scene]()
    planner = lab_planner(enable_homotopy_class_planning=homotopy, include_dynamic_obstacles=dynamic)
    planner.set_plan(plan)
    pose, vel, cycles = np.array(start, dtype=float), (0.0, 0.0), []
    for _ in range(CYCLES):
        if moving is not None:
            planner.set_dynamic_obstacles(moving + [pose[0], pose[1], 0.0, 0.0, 0.0])
        result = planner.compute_velocity_commands(pose, vel, rolling_costmap(pose[0], pose[1], obstacles))
        bands = [(c.band.poses.copy(), c.band.time_diffs.copy()) for c in planner.planner.candidates]
        cycles.append((result.v, result.omega, result.ok, bands))
        if result.goal_reached:
            break
        pose, vel = unicycle_step(pose, result.v, result.omega), (result.v, result.omega)
    return cycles


def assert_identical(first: list[tuple], second: list[tuple]) -> None:
    assert any(v > 0.05 for v, *_ in first), "the robot never drove: the comparison proves nothing"
    assert len(first) == len(second), f"{len(first)} against {len(second)} cycles"
    for cycle, ((v0, w0, ok0, bands0), (v1, w1, ok1, bands1)) in enumerate(zip(first, second)):
        assert (v0, w0, ok0) == (v1, w1, ok1), f"cycle {cycle}: command {(v0, w0, ok0)} against {(v1, w1, ok1)}"
        assert len(bands0) == len(bands1), f"cycle {cycle}: {len(bands0)} against {len(bands1)} candidate bands"
        for (poses0, dts0), (poses1, dts1) in zip(bands0, bands1):
            assert np.array_equal(poses0, poses1) and np.array_equal(dts0, dts1), f"cycle {cycle}: the bands differ"


@pytest.fixture(autouse=True)
def unlimited_cycle_budget(monkeypatch):
    monkeypatch.setattr(planner_module, "CYCLE_BUDGET_FRACTION", 1e9)


@pytest.mark.parametrize("homotopy", [False, True], ids=["hcp=False", "hcp=True"])
@pytest.mark.parametrize("scene", list(SCENES))
def test_include_dynamic_obstacles_without_a_moving_obstacle_is_static_teb(scene, homotopy):
    assert_identical(closed_loop(scene, homotopy, False), closed_loop(scene, homotopy, True))


@pytest.mark.parametrize("homotopy", [False, True], ids=["hcp=False", "hcp=True"])
@pytest.mark.parametrize("scene", list(SCENES))
def test_a_moving_obstacle_far_away_changes_nothing(scene, homotopy):
    assert_identical(closed_loop(scene, homotopy, True), closed_loop(scene, homotopy, True, FAR_AWAY))
