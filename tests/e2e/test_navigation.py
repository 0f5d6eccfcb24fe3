"""End to end: simulator + move_base from the navigation launch file, in lockstep, goals through the action.

Every test gets a fresh session (the lab's box robot unless said otherwise); budgets are sim time,
and the wall-clock guard only turns a hang into a failure.
"""

import math

import numpy as np
import pytest

from simplebot_navigation.scenarios import NavigationSession, run_goal
from simplebot_navigation.sim.world import Pose2D

pytestmark = pytest.mark.timeout(1500)

WALL_GUARD_S = 600.0  # per advance: only a hang should reach it
# Lab rooms entered through one door each: goal, the wall line y, the door's clear x-range.
NORTH_MEETING = (Pose2D(1.5, 3.5, math.pi / 2, "north meeting room"), 1.25, (0.9, 2.1))
SOUTH_MEETING = (Pose2D(0.0, -3.0, -math.pi / 2, "south meeting room"), -1.25, (-0.6, 0.6))
OPEN_PLAN = (Pose2D(-5.0, -3.0, -math.pi / 2, "open-plan office"), -1.25, (-5.7, -4.3))


@pytest.fixture
def lab():
    with NavigationSession("lab") as session:
        session.wait_ready(wall_timeout_s=60)
        yield session


def crossings(trajectory, y_line: float) -> list[float]:
    """x where the trajectory crosses the horizontal line y = y_line."""
    t = np.asarray(trajectory)
    xs = []
    for (x0, y0), (x1, y1) in zip(t[:-1, 1:3], t[1:, 1:3]):
        if (y0 - y_line) * (y1 - y_line) < 0:
            xs.append(x0 + (x1 - x0) * (y_line - y0) / (y1 - y0))
    return xs


def speed(session: NavigationSession, since: float) -> float:
    """Largest ground-truth speed (m/s) since a sim time."""
    t = np.asarray(session.truth_since(since))
    return float(np.max(np.hypot(*np.diff(t[:, 1:3], axis=0).T) / np.diff(t[:, 0])))


def test_lab_three_rooms_through_their_doors(lab):
    for goal, wall_y, (door_x0, door_x1) in (NORTH_MEETING, SOUTH_MEETING, OPEN_PLAN):
        budget = 20.0 + 2.5 * 12.0 / 0.4
        result = run_goal(lab, goal, budget, wall_timeout_s=WALL_GUARD_S)
        assert result.success, f"{goal.name}: {result.failures}"
        assert result.collisions == 0
        assert result.min_clearance > 0.0
        crossed = crossings(result.trajectory, wall_y)
        assert crossed and door_x0 < crossed[-1] < door_x1, \
            f"{goal.name}: entered at x = {crossed} (door {door_x0}..{door_x1})"


def test_goal_inside_an_obstacle_is_refused_and_the_next_goal_works(lab):
    table = Pose2D(0.0, 5.5, 0.0, "inside the meeting table")
    run = lab.send_goal(table)
    lab.run_until(lab.time + 120.0, lambda: run.done, wall_timeout_s=WALL_GUARD_S)
    assert run.status in ("ABORTED", "REJECTED"), f"after 120 s sim: {run.status}, {lab.move_base.state}"
    assert run.reason, "no reason in /move_base/status"
    assert lab.client.collisions == 0
    corridor = Pose2D(-2.0, 0.0, math.pi, "corridor")
    result = run_goal(lab, corridor, 60.0, wall_timeout_s=WALL_GUARD_S)
    assert result.success, result.failures


def test_a_new_goal_preempts_the_running_one(lab):
    first = lab.send_goal(Pose2D(8.0, 0.0, 0.0, "east end"))
    lab.run_for(6.0, lambda: first.done, wall_timeout_s=WALL_GUARD_S)
    assert not first.done and lab.pose().x > 0.3, "the first goal should be under way"
    second = lab.send_goal(Pose2D(-2.0, 0.0, math.pi, "west"))
    lab.run_for(1.0, lambda: first.done, wall_timeout_s=WALL_GUARD_S)
    assert first.status in ("ABORTED", "CANCELED"), first.status
    lab.run_until(second.sent_at + 60.0, lambda: second.done, wall_timeout_s=WALL_GUARD_S)
    assert second.status == "SUCCEEDED", (second.status, second.reason)
    assert math.hypot(lab.pose().x + 2.0, lab.pose().y) < 0.2


def test_cancel_stops_the_robot(lab):
    run = lab.send_goal(Pose2D(8.0, 0.0, 0.0, "east end"))
    lab.run_for(6.0, wall_timeout_s=WALL_GUARD_S)
    assert speed(lab, lab.time - 0.5) > 0.1, "the robot should be driving"
    lab.cancel(run)
    lab.run_for(2.0, lambda: run.done, wall_timeout_s=WALL_GUARD_S)
    assert run.status == "CANCELED"
    lab.run_for(1.5, wall_timeout_s=WALL_GUARD_S)  # braking at the acceleration limit
    stopped_at = lab.time
    lab.run_for(2.0, wall_timeout_s=WALL_GUARD_S)
    assert speed(lab, stopped_at) < 0.01
    assert lab.move_base.state == "IDLE"


BLOCKED = """\
name: blocked
walls:
  - {from: [-2.0, -1.25], to: [10.0, -1.25]}
  - {from: [-2.0, 1.25], to: [10.0, 1.25]}
  - {from: [-2.0, -1.25], to: [-2.0, 1.25]}
  - {from: [10.0, -1.25], to: [10.0, 1.25]}
boxes:
  - {center: [4.0, 0.0], size: [0.4, 2.4], name: blockade}
start: {x: 0.0, y: 0.0, yaw: 0.0}
goals:
  - {x: 8.0, y: 0.0, yaw: 0.0, name: beyond}
"""


def test_a_blocked_corridor_ends_in_recoveries_and_an_abort(tmp_path):
    world = tmp_path / "blocked.yaml"
    world.write_text(BLOCKED)
    with NavigationSession(str(world)) as session:
        session.wait_ready(wall_timeout_s=60)
        run = session.send_goal(session.world.goal("beyond"))
        session.run_until(session.time + 180.0, lambda: run.done, wall_timeout_s=WALL_GUARD_S)
        assert run.status == "ABORTED", f"after 180 s sim: {run.status}, state {session.move_base.state}"
        assert run.reason
        assert session.move_base.recoveries >= 1
        assert session.client.collisions == 0
        assert session.pose().x < 4.0 - 0.2 - 0.45
