"""Stopping from 2 m/s as a safety invariant of the whole stack (issue 28, item 4), in lockstep.

The round body r = 0.25 m with the Jackal drive and ``max_speed`` 2.0 (the narrow-passage set, as the forest
benchmark at 2 m/s runs) drives down a 2.8 m corridor towards a goal 16 m ahead. Once it is at full speed, a
box as wide as the corridor appears across it, 2 m or 3 m ahead of the body's front. Nothing is told of it:
the simulator's lidars see it at their next scan, and move_base and the collision monitor must stop the robot
short of it. tests/sim/test_jackal_drive.py measures what the drive alone can do (zero commanded the moment
the obstacle appears); this measures what the stack does, against the same physical minimum v^2 / (2 a).
"""

import numpy as np
import pytest

from simplebot_navigation.scenarios import NavigationSession
from simplebot_navigation.sim.diff_drive import JACKAL_ACCEL
from simplebot_navigation.sim.world import Pose2D

pytestmark = [pytest.mark.timeout(300), pytest.mark.e2e]

RADIUS = 0.25
SPEED = 2.0
#: the corridor's inner faces at y = +-HALF_WIDTH; the goal at its far end
HALF_WIDTH = 1.4
GOAL = Pose2D(16.0, 0.0, 0.0)
#: the box that appears: this deep along the corridor, as wide as it; parked out of sight and reach until then
DEPTH = 0.2
PARKED = (0.0, 40.0)
#: the box appears once the robot's centre is this far down the corridor (full speed from about 1 m on) and it is
#: at full speed: TEB's command dips to about 1.9 m/s for a cycle now and then, and which cycle that is depends on
#: the CPU's floating point, so a fixed trigger point alone may catch a dip on one machine and not on another
TRIGGER_X = 4.0
FULL_SPEED = 0.97 * SPEED
#: simulated time watched after the box appears: the robot's forward motion ends after 1.4 s (2 m) and 2.1 s (3 m)
WATCH_S = 3.0
WORLD = f"""name: corridor
walls:
  - {{from: [-2.0, {HALF_WIDTH + 0.1}], to: [30.0, {HALF_WIDTH + 0.1}], thickness: 0.2, height: 1.0}}
  - {{from: [-2.0, {-HALF_WIDTH - 0.1}], to: [30.0, {-HALF_WIDTH - 0.1}], thickness: 0.2, height: 1.0}}
boxes: []
cylinders: []
moving:
  - {{shape: box, size: [{DEPTH}, {2 * HALF_WIDTH}], keyframes: [[0.0, {PARKED[0]}, {PARKED[1]}],
                                                             [1.0, {PARKED[0]}, {PARKED[1]}]]}}
start: {{x: 0.0, y: 0.0, yaw: 0.0}}
goals: [{{x: {GOAL.x}, y: {GOAL.y}, yaw: 0.0, name: end}}]
"""


@pytest.fixture(scope="module")
def corridor(tmp_path_factory):
    path = tmp_path_factory.mktemp("worlds") / "corridor.yaml"
    path.write_text(WORLD)
    return str(path)


@pytest.mark.parametrize("gap", [2.0, 3.0])
def test_the_stack_stops_short_of_an_obstacle_appearing_ahead_at_2_m_s(corridor, gap):
    _stops_short(corridor, gap, collision_monitor=True)


@pytest.mark.parametrize("gap", [2.0, 3.0])
def test_move_base_alone_stops_short_of_an_obstacle_appearing_ahead_at_2_m_s(corridor, gap):
    """Without the collision monitor: TEB alone must brake at its acc_lim_x. It used to run into the box from both
    distances (at 1.2 m/s from 2 m, 0.7 m/s from 3 m), its commands alternating between braking and speeding up
    because a warm-started band kept its first segment's time whatever the robot had driven meanwhile (and the
    band's resizing retimed that segment without moving its poses)."""
    _stops_short(corridor, gap, collision_monitor=False)


def _stops_short(corridor, gap, collision_monitor):
    with NavigationSession(corridor, robot="round", radius=RADIUS, tight=True, max_speed=SPEED,
                           collision_monitor=collision_monitor) as session:
        sim = session.sim.sim
        truth: list[tuple[float, float, float, float]] = []     # (t, x, y, vx) after every lockstep event
        session.driver.on_step(lambda: truth.append((sim.sim_time, *_xyv(sim.ground_truth()))))
        session.wait_ready(wall_timeout_s=120)
        session.send_goal(GOAL)
        session.run_until(None, lambda: sim.ground_truth().x >= TRIGGER_X and sim.ground_truth().vx > FULL_SPEED,
                          wall_timeout_s=120)

        # From the next physics step on, the box stands across the corridor `gap` ahead of the body's front.
        now = session.time
        face = sim.ground_truth().x + RADIUS + gap
        sim.set_moving_keyframes(0, [(0.0, *PARKED), (now, *PARKED), (now + sim.dt, face + DEPTH / 2, 0.0)])
        appeared = now + sim.dt
        session.run_until(appeared + WATCH_S, wall_timeout_s=120)
        collisions = sim.collisions()
        client_collisions = session.client.collisions

    track = np.array([row for row in truth if row[0] >= appeared - 1e-9])
    t, x, y, v = track.T
    v0, gap0 = v[0], face - (x[0] + RADIUS)
    standing = np.flatnonzero(v < 0.01)          # forward motion ends (it may turn back at once, as it does)
    assert v0 > FULL_SPEED, f"only {v0:.2f} m/s when the box appeared"
    assert gap0 == pytest.approx(gap, abs=0.05)
    assert collisions.count == 0 and not collisions.in_contact and client_collisions == 0, collisions
    assert len(standing), f"still at {v[-1]:.2f} m/s {WATCH_S:g} s after the box appeared"
    assert np.abs(y).max() < HALF_WIDTH - RADIUS                 # it stayed in the corridor, in front of the box

    stop = standing[0]
    closest = face - (x.max() + RADIUS)
    braking_from = np.flatnonzero(v < v0 - 0.05)[0]
    travel, braking = x[stop] - x[0], x[stop] - x[braking_from]
    minimum = v0 ** 2 / (2 * JACKAL_ACCEL)
    print(f"box appearing {gap0:.2f} m ahead at {v0:.2f} m/s: braking began {t[braking_from] - t[0]:.2f} s later, "
          f"standing {t[stop] - t[0]:.2f} s after it appeared, {travel:.2f} m on ({braking:.2f} m braking); "
          f"v^2 / (2 a) = {minimum:.3f} m (ratio {travel / minimum:.2f}); {closest:.3f} m left")
    assert closest > 0.05, f"stopped {closest:.3f} m from the box"
    # Nothing stops quicker than the drive's deceleration allows (a sanity check of the measurement).
    assert braking >= minimum - SPEED * sim.dt


def _xyv(g) -> tuple[float, float, float]:
    return g.x, g.y, g.vx
