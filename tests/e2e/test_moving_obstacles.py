"""Moving obstacles end to end, in lockstep: a crowd world of each level and people walking in the lab's corridor, at
both speed settings, with the defaults: TEB drives, MPPI while moving obstacles are near (docs/design.md §7.1).

The round body r = 0.25 m at 1 and 2 m/s (max_speed) with the narrow-passage set and prediction on (the crowd
campaign's set, CROWD below), on worlds it crosses in the benchmark campaigns (BENCHMARKS.md). While the robot drives, the
local costmap is checked every half second for stale marks: a lethal cell that neither a wall nor a moving
obstacle's place during the last second explains.
"""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.mppi.plugin import MPPI_LOCAL_PLANNER
from simplebot_navigation.scenarios import NavigationSession, run_goal
from simplebot_navigation.scenarios.runner import time_budget
from simplebot_navigation.sim.moving import MovingTracks

pytestmark = [pytest.mark.timeout(1200), pytest.mark.e2e]

#: the defaults track and predict moving obstacles; the crowd arena's goal lies 20 m ahead: the global costmap must
#: reach past it
CROWD = ("global_costmap.width=50.0", "global_costmap.height=50.0", "global_costmap.origin_x=-25.0",
                      "global_costmap.origin_y=-25.0")
STALE_AFTER_S = 1.0
#: a mark that went stale is cleared by the next scan (10 Hz) the local costmap processes (10 Hz updates): so a
#: cell counts as stale once nothing explained it for STALE_AFTER_S plus one scan and one update period
CLEARING_LAG_S = 0.2
#: cells within this of a wall or of a moving obstacle's recent place are explained (two cells and the
#: clearing margin)
EXPLAINED_M = 0.2
CHECK_PERIOD_S = 0.5


class StaleMarks:
    """Samples the local costmap while the session runs: the lethal cells nothing explains."""

    def __init__(self, session):
        self.session = session
        self.world = session.world
        self.tracks = MovingTracks(self.world.moving)
        start = self.world.start
        self.odom_to_world = (start.x, start.y, start.yaw)
        self.next_check = 0.0
        self.worst: tuple[int, float] = (0, math.nan)

    def __call__(self) -> bool:
        now = self.session.time
        if now >= self.next_check:
            self.next_check = now + CHECK_PERIOD_S
            count = self.count(now)
            if count > self.worst[0]:
                self.worst = (count, now)
        return False

    def count(self, now: float) -> int:
        costmap_ros = self.session.move_base.local_costmap
        with costmap_ros.lock:
            costmap = costmap_ros.costmap
            my, mx = np.nonzero(costmap.costmap == LETHAL_OBSTACLE)
        if not len(mx):
            return 0
        ox, oy, oyaw = self.odom_to_world
        x = costmap.origin_x + (mx + 0.5) * costmap.resolution
        y = costmap.origin_y + (my + 0.5) * costmap.resolution
        c, s = math.cos(oyaw), math.sin(oyaw)
        cells = np.column_stack([ox + c * x - s * y, oy + s * x + c * y])
        unexplained = self.world.distance(cells) > EXPLAINED_M
        for t in np.arange(now - STALE_AFTER_S - CLEARING_LAG_S, now + 1e-9, 0.05):
            states = self.tracks.states(float(t))
            near = np.hypot(cells[:, None, 0] - states[:, 0], cells[:, None, 1] - states[:, 1]) \
                <= self.tracks.reach + EXPLAINED_M
            unexplained &= ~near.any(axis=1)
        return int(unexplained.sum())


def drive(world, overrides, speed=1.0):
    """The round body at ``speed`` (max_speed) with the narrow-passage set, as in the campaigns."""
    with NavigationSession(world, robot="round", radius=0.25, tight=True, overrides=overrides,
                           max_speed=speed) as session:
        session.wait_ready(wall_timeout_s=120)
        goal = session.world.goal("goal")
        stale = StaleMarks(session)
        original = session.run_until

        def run_until(sim_time_s=None, stop=None, wall_timeout_s=None):
            return original(sim_time_s, lambda: stale() or (stop is not None and stop()), wall_timeout_s)

        session.run_until = run_until
        max_vel_x = session.controller_param("max_vel_x", 0.4)
        result = run_goal(session, goal, time_budget(session.world, session.pose(), goal, max_vel_x),
                          wall_timeout_s=600)
        return result, *stale.worst


def assert_crossed(world, result, stale, when):
    print(f"{world}: {result.status} in {result.time_s:.1f} s, clearance {result.min_clearance:.2f} m, "
          f"collisions {result.collisions}, struck standing {result.struck_standing}; "
          f"most unexplained lethal cells {stale} (t = {when:.1f} s)")
    assert result.success, result.failures
    assert result.collisions == 0
    assert stale == 0, f"{stale} lethal cells at t = {when:.1f} s that no wall or recent obstacle explains"


CROSSED = [(1.0, "crowd:0", "easy"), (1.0, "crowd:13", "medium"), (1.0, "crowd:26", "hard"),
           (2.0, "crowd:0", "easy"), (2.0, "crowd:4", "medium"), (2.0, "crowd:26", "hard")]


@pytest.mark.parametrize("speed, world, level", CROSSED, ids=[f"{level}@{speed:g}" for speed, _, level in CROSSED])
def test_the_round_robot_crosses_a_crowd(speed, world, level):
    result, *stale = drive(world, CROWD, speed)
    assert_crossed(world, result, *stale)
    assert result.handovers.get(MPPI_LOCAL_PLANNER), f"the crowd planner never drove: {result.handovers}"


@pytest.mark.parametrize("speed", [1.0, 2.0], ids=["1", "2"])
def test_people_walk_past_in_the_lab(speed):
    assert_crossed("people:3", *drive("people:3", (), speed))
