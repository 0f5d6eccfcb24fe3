"""The three-robot swap in the lab (``multi_navigation``): robot1 drives to robot2's start, robot2 to robot3's and
robot3 to robot1's, so robot2 and robot3 meet in the corridor and at the lab's door. The same scenario is an
end-to-end test in lockstep (tests/e2e/test_multi_robot.py) and a real-time benchmark (bench/swap.py); this module
holds what both measure."""

from __future__ import annotations

import itertools
import math

from simplebot_navigation.sim.world import Pose2D

NAMESPACES = ("robot1", "robot2", "robot3")
#: slower than this (m/s, over a ground-truth sample) is standing
STANDING_SPEED = 0.02
Truth = list[tuple[float, float, float, float]]      # (t, x, y, yaw) in the world frame


def swap_goals(starts: list[Pose2D]) -> list[Pose2D]:
    """Each robot's goal: the next robot's start."""
    return starts[1:] + starts[:1]


def closest_approach(truths: list[Truth]) -> float:
    """The smallest distance between two robots' base_links, over the ground truth stamps they share."""
    tracks = [{t: (x, y) for t, x, y, _ in truth} for truth in truths]
    return min(math.dist(a[t], b[t]) for a, b in itertools.combinations(tracks, 2) for t in a.keys() & b.keys())


def longest_standstill(truth: Truth, t0: float) -> tuple[float, float]:
    """(seconds, start) of the longest stretch from t0 to the robot's last movement in which it stood still: a
    robot at its goal stands, and that does not count."""
    moved = [a[0] for a, b in zip(truth, truth[1:]) if math.hypot(b[1] - a[1], b[2] - a[2]) > 1e-3]
    t1 = moved[-1] if moved else t0
    samples = [s for s in truth if t0 <= s[0] <= t1]
    longest, began, since = 0.0, math.nan, None
    for (ta, xa, ya, _), (tb, xb, yb, _) in zip(samples, samples[1:]):
        if tb > ta and math.hypot(xb - xa, yb - ya) / (tb - ta) < STANDING_SPEED:
            since = ta if since is None else since
            if tb - since > longest:
                longest, began = tb - since, since
        else:
            since = None
    return longest, began
