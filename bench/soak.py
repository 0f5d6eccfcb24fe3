"""Soak: hours of simulated driving in lockstep, watching the process for growth.

    python bench/soak.py [--world lab] [--sim-minutes 120] [--seed 0]

The simulator and move_base of ``navigation`` run in this process in lockstep (as the scenario
runner does) and drive to goals of the world drawn at random (seeded), one after another, for the
given simulated time. Every simulated minute the process's resident memory, open file
descriptors and threads are sampled; the table ends with their growth from minute 10 (start-up,
caches and compiled kernels settled) to the end. The client keeps only the current goal's ground
truth, so what grows is the navigation stack.
"""

from __future__ import annotations

import argparse
import os
import random
import time

from simplebot_navigation.scenarios.runner import run_goal, time_budget
from simplebot_navigation.scenarios.session import NavigationSession

SAMPLE_PERIOD_S = 60.0
SETTLED_MINUTE = 10


def process_sample() -> tuple[float, int, int]:
    """(resident memory in MB, open file descriptors, threads) of this process."""
    fields = {}
    with open("/proc/self/status", encoding="ascii") as status:
        for line in status:
            key, _, value = line.partition(":")
            fields[key] = value.split()
    return int(fields["VmRSS"][0]) / 1024.0, len(os.listdir("/proc/self/fd")), int(fields["Threads"][0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="lab")
    parser.add_argument("--sim-minutes", type=float, default=120.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    wall_start = time.monotonic()
    samples: list[tuple[int, float, int, int, int, int]] = []   # minute, rss, fds, threads, goals, reached
    goals = reached = 0
    with NavigationSession(args.world, seed=args.seed) as session:
        session.wait_ready(wall_timeout_s=300.0)
        start = session.time
        next_sample = start
        max_vel_x = session.controller_param("max_vel_x", 0.4)
        while session.time - start < args.sim_minutes * 60.0:
            goal = rng.choice(session.world.goals)
            result = run_goal(session, goal, time_budget(session.world, session.pose(), goal, max_vel_x),
                              wall_timeout_s=600.0)
            session.client.truth.clear()
            goals += 1
            reached += result.success
            if result.status == "HUNG":
                print(f"the nodes hung at sim {session.time:.0f} s: {result.failures}")
                break
            while session.time >= next_sample:
                minute = round((next_sample - start) / 60.0)
                samples.append((minute, *process_sample(), goals, reached))
                rss, fds, threads = samples[-1][1:4]
                print(f"minute {minute:4d}  rss {rss:7.1f} MB  fds {fds:4d}  threads {threads:3d}  "
                      f"goals {goals:4d} reached {reached:4d}  wall {time.monotonic() - wall_start:6.0f} s",
                      flush=True)
                next_sample += SAMPLE_PERIOD_S
    print()
    print(f"{'minute':>6s} {'rss MB':>8s} {'fds':>5s} {'threads':>7s} {'goals':>6s} {'reached':>7s}")
    for minute, rss, fds, threads, n, ok in samples:
        print(f"{minute:6d} {rss:8.1f} {fds:5d} {threads:7d} {n:6d} {ok:7d}")
    settled = next((s for s in samples if s[0] >= SETTLED_MINUTE), None)
    if settled is not None and samples[-1][0] > settled[0]:
        last = samples[-1]
        print(f"growth minute {settled[0]} -> {last[0]}: rss {100 * (last[1] / settled[1] - 1):+.1f} %, "
              f"fds {last[2] - settled[2]:+d}, threads {last[3] - settled[3]:+d}; "
              f"{reached}/{goals} goals reached; {time.monotonic() - wall_start:.0f} s wall")


if __name__ == "__main__":
    main()
