"""Soak: hours of simulated driving with random sensor dropouts, watching each process for growth.

    python bench/soak.py [--world lab] [--sim-minutes 120] [--seed 0] [--dropouts-per-minute 1]
    python bench/soak.py --processes [--rtf 2] ...

By default the simulator and move_base of ``navigation`` run in this process in lockstep (as the
scenario runner does); with ``--processes`` the launcher runs them as its own processes at ``--rtf``
(respawn off, so a crash ends the soak). The robot drives to goals of the world drawn at random
(seeded), one after another, for the given simulated time. Meanwhile the simulator's fault
parameters drop a lidar, both lidars or odometry for 1-4 s at random (on average
``--dropouts-per-minute``). Every simulated minute the resident memory, open file descriptors and
threads of each process are sampled; the table ends with their growth from minute 10 (start-up,
caches and compiled kernels settled) to the end. The client keeps only the current goal's ground
truth, so what grows is the navigation stack.
"""

from __future__ import annotations

import argparse
import os
import random
import time

from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

from simplebot_navigation.scenarios.runner import run_goal, time_budget
from simplebot_navigation.scenarios.process_session import ProcessSession
from simplebot_navigation.scenarios.session import NavigationSession

SAMPLE_PERIOD_S = 60.0
SETTLED_MINUTE = 10
DROPOUTS = (("faults.scan_dropout", "front_laser_link", ""), ("faults.scan_dropout", "back_laser_link", ""),
            ("faults.scan_dropout", "all", ""), ("faults.odometry_dropout", True, False))


def process_sample(pid: int | str = "self") -> tuple[float, int, int]:
    """(resident memory in MB, open file descriptors, threads) of a process."""
    fields = {}
    with open(f"/proc/{pid}/status", encoding="ascii") as status:
        for line in status:
            key, _, value = line.partition(":")
            fields[key] = value.split()
    return int(fields["VmRSS"][0]) / 1024.0, len(os.listdir(f"/proc/{pid}/fd")), int(fields["Threads"][0])


class RandomDropouts:
    """Once a simulated second, with probability rate/60, a random sensor fault for 1-4 s."""

    def __init__(self, session, rate_per_minute: float, rng: random.Random):
        self.session, self.rng, self.probability = session, rng, rate_per_minute / 60.0
        self.count = 0
        self._ends_at: float | None = None
        self._clear: Parameter | None = None
        self._remote = AsyncParameterClient(session.client, "/simulator") if isinstance(session, ProcessSession) \
            else None
        session.client.create_timer(1.0, self._tick)

    def _set(self, param: Parameter) -> None:
        if self._remote is not None:
            self._remote.set_parameters([param])
        else:
            result = self.session.sim.set_parameters([param])[0]
            assert result.successful, result.reason

    def _tick(self) -> None:
        now = self.session.time
        if self._ends_at is not None:
            if now >= self._ends_at:
                self._set(self._clear)
                self._ends_at = None
            return
        if self.rng.random() < self.probability:
            name, value, cleared = self.rng.choice(DROPOUTS)
            self._set(Parameter(name, value=value))
            self._clear = Parameter(name, value=cleared)
            self._ends_at = now + self.rng.uniform(1.0, 4.0)
            self.count += 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="lab")
    parser.add_argument("--sim-minutes", type=float, default=120.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dropouts-per-minute", type=float, default=1.0)
    parser.add_argument("--processes", action="store_true", help="the launcher's processes instead of lockstep")
    parser.add_argument("--rtf", type=float, default=2.0, help="real-time factor with --processes")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    wall_start = time.monotonic()
    samples: list[tuple[int, dict, int, int]] = []   # minute, {process: (rss, fds, threads)}, goals, reached
    goals = reached = 0
    session = (ProcessSession(args.world, seed=args.seed, rtf=args.rtf) if args.processes
               else NavigationSession(args.world, seed=args.seed))
    with session:
        session.wait_ready(wall_timeout_s=300.0)
        pids = ({name: session.node_pid(name) for name in ("simulator", "move_base")} if args.processes
                else {"simulator+move_base": "self"})
        dropouts = RandomDropouts(session, args.dropouts_per_minute, rng)
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
                sample = {name: process_sample(pid) for name, pid in pids.items()}
                samples.append((minute, sample, goals, reached))
                print(f"minute {minute:4d}  " + "  ".join(
                    f"{name}: rss {rss:6.1f} MB fds {fds:3d} threads {threads:3d}"
                    for name, (rss, fds, threads) in sample.items())
                    + f"  goals {goals:4d} reached {reached:4d} dropouts {dropouts.count:4d}"
                    f"  wall {time.monotonic() - wall_start:6.0f} s", flush=True)
                next_sample += SAMPLE_PERIOD_S
    print()
    names = list(pids)
    print(f"{'minute':>6s} " + " ".join(f"{n + ' rss MB':>24s} {'fds':>4s} {'thr':>4s}" for n in names)
          + f" {'goals':>6s} {'reached':>7s}")
    for minute, sample, n, ok in samples:
        print(f"{minute:6d} " + " ".join(f"{sample[name][0]:24.1f} {sample[name][1]:4d} {sample[name][2]:4d}"
                                         for name in names) + f" {n:6d} {ok:7d}")
    settled = next((s for s in samples if s[0] >= SETTLED_MINUTE), None)
    if settled is not None and samples[-1][0] > settled[0]:
        last = samples[-1]
        for name in names:
            (rss0, fds0, thr0), (rss1, fds1, thr1) = settled[1][name], last[1][name]
            print(f"{name}: growth minute {settled[0]} -> {last[0]}: rss {100 * (rss1 / rss0 - 1):+.1f} % "
                  f"(max {100 * (max(s[1][name][0] for s in samples if s[0] >= SETTLED_MINUTE) / rss0 - 1):+.1f} %), "
                  f"fds {fds1 - fds0:+d} ({100 * (fds1 / fds0 - 1):+.1f} %), "
                  f"threads {thr1 - thr0:+d} ({100 * (thr1 / thr0 - 1):+.1f} %)")
        print(f"{reached}/{goals} goals reached, {dropouts.count} sensor dropouts; "
              f"{time.monotonic() - wall_start:.0f} s wall")


if __name__ == "__main__":
    main()
