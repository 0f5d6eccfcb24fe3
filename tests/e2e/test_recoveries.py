"""A box body nosed into a dead end 0.8 m wide, where it cannot turn (its diagonal is 1.08 m), with the
narrow-passage set: it reverses out to a goal behind it, and its recoveries back it out along the way it
came when a plan fails there."""

import math

import pytest

from simplebot_navigation.scenarios import NavigationSession, run_goal
from simplebot_navigation.sim.world import Pose2D

pytestmark = [pytest.mark.timeout(900), pytest.mark.e2e]

WALL_GUARD_S = 600.0
POCKET = """\
name: pocket
walls:
  - {from: [-6.0, -4.0], to: [3.0, -4.0], thickness: 0.2}
  - {from: [3.0, -4.0], to: [3.0, 4.0], thickness: 0.2}
  - {from: [3.0, 4.0], to: [-6.0, 4.0], thickness: 0.2}
  - {from: [-6.0, 4.0], to: [-6.0, -4.0], thickness: 0.2}
  # the dead end: open to the west, inner faces at y = +-0.4 and x = 1.45
  - {from: [-0.5, 0.45], to: [1.5, 0.45], thickness: 0.1}
  - {from: [-0.5, -0.45], to: [1.5, -0.45], thickness: 0.1}
  - {from: [1.5, -0.5], to: [1.5, 0.5], thickness: 0.1}
start: {x: 0.9, y: 0.0, yaw: 0.0}
goals:
  - {x: -3.0, y: 2.0, yaw: 1.5708, name: out}
  - {x: -2.5, y: 0.0, yaw: 0.0, name: before}
  - {x: 0.8, y: 0.0, yaw: 0.0, name: inside}
"""


def test_the_box_reverses_out_of_a_dead_end_it_cannot_turn_in(tmp_path):
    world = tmp_path / "pocket.yaml"
    world.write_text(POCKET)
    with NavigationSession(str(world), tight=True) as session:
        session.wait_ready(wall_timeout_s=60)
        result = run_goal(session, session.world.goal("out"), 60.0, wall_timeout_s=WALL_GUARD_S)
    assert result.success, result.failures
    assert result.collisions == 0
    assert result.path_length < 7.0      # out and round, not back and forth in the dead end


def test_recoveries_back_the_box_out_of_a_dead_end_where_it_cannot_turn(tmp_path):
    world = tmp_path / "pocket.yaml"
    world.write_text(POCKET.replace("start: {x: 0.9, y: 0.0, yaw: 0.0}", "start: {x: -2.5, y: 0.0, yaw: 0.0}"))
    with NavigationSession(str(world), tight=True) as session:
        session.wait_ready(wall_timeout_s=60)
        inside = run_goal(session, session.world.goal("inside"), 40.0, wall_timeout_s=WALL_GUARD_S)
        assert inside.success, inside.failures
        t0 = session.time
        # a goal in the dead end's end wall, which the front lidar keeps marking: no plan, whatever is cleared
        trapped = run_goal(session, Pose2D(1.5, 0.0, 0.0), 120.0, wall_timeout_s=WALL_GUARD_S)
        events = session.stats().navigation.recent
        driven = session.truth_since(t0)
    assert trapped.status == "ABORTED" and trapped.reason.startswith("Failed to find a valid plan")
    ran = [e.detail.split()[0] for e in events if e.kind == "recovery" and e.stamp >= t0]
    assert ran == ["conservative_reset", "back_up", "spin", "aggressive_reset", "back_up_further", "rotate_recovery"]
    assert trapped.collisions == 0 and inside.collisions == 0
    start, end = driven[0], driven[-1]
    assert start[1] - end[1] == pytest.approx(0.3 + 0.6, abs=0.1)        # backed up 0.3 m, then 0.6 m ...
    assert max(abs(p[2]) for p in driven) < 0.15                         # ... straight along the way in
    assert max(abs(math.remainder(p[3], 2 * math.pi)) for p in driven) < 0.3   # the spin could turn only a little
