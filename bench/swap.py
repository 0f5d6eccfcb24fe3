"""The three-robot swap at real time, as the launcher's processes (``multi_navigation`` in the lab, the obstacle
tracker on): what tests/e2e/test_multi_robot.py checks in lockstep, here where the machine's load can make the
three move_bases, their collision monitors and the simulator late.

    .venv/bin/python bench/swap.py [--runs 2] [--stress 2] [--rtf 1.0]

Each run starts the launcher, sends each robot its goal (the next robot's start) in ``map`` and waits up to 480 s
of wall clock. It reports, per run: each robot's outcome, the swap's simulated time (until the last goal ended),
the closest approach of two robots, the longest standstill of a robot while its goal was active (until its last
movement) and collisions. Runs: --runs at the machine's load, then --runs beside --stress busy loops (0: none).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[0] = str(ROOT)

from simplebot_navigation.scenarios.campaign.execution import domain_lease  # noqa: E402
from simplebot_navigation.testing.proc_stats import loadavg, start_stress, stop_stress  # noqa: E402

DRIVE_WALL_S = 480.0
STATUS = {4: "SUCCEEDED", 5: "CANCELED", 6: "ABORTED"}


def swap(rtf: float) -> dict:
    from simplebot_navigation.scenarios.process_session import ProcessSession
    from simplebot_navigation.scenarios.session import ScenarioClient, goal_in_map
    from simplebot_navigation.scenarios.swap import NAMESPACES, closest_approach, longest_standstill, swap_goals
    from simplebot_navigation.sim.world_loader import load_world

    with ProcessSession("lab", rtf=rtf, launch_file="multi_navigation") as session:
        clients = [ScenarioClient(session.context, namespace) for namespace in NAMESPACES]
        for client in clients:
            session.executor.add_node(client)
        if not session.spin_wall(240.0, lambda: all(c.action.server_is_ready() and c.truth for c in clients)):
            raise RuntimeError("the three move_base actions never became ready")
        goals = swap_goals(load_world("lab").starts)
        sent = [client.action.send_goal_async(goal_in_map(goal)) for client, goal in zip(clients, goals)]
        if not session.spin_wall(30.0, lambda: all(f.done() for f in sent)) or not all(f.result().accepted
                                                                                    for f in sent):
            raise RuntimeError("a goal was not accepted")
        results = [f.result().get_result_async() for f in sent]
        t0, started = session.time, time.monotonic()
        session.spin_wall(DRIVE_WALL_S, lambda: all(r.done() for r in results))
        outcome = {
            "swap_s": session.time - t0, "wall_s": time.monotonic() - started, "load1": loadavg(),
            "closest_m": closest_approach([c.truth for c in clients]),
            "status": [STATUS.get(r.result().status, str(r.result().status)) if r.done() else "RUNNING"
                       for r in results],
            "standstill_s": [longest_standstill(c.truth, t0)[0] for c in clients],
            "collisions": [c.collisions for c in clients],
        }
        for client in clients:
            session.executor.remove_node(client)
            client.destroy_node()
        return outcome


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=2, help="runs at each load (1 to 20)")
    parser.add_argument("--stress", type=int, default=2, help="busy-loop processes of the stress runs (0 to 8)")
    parser.add_argument("--rtf", type=float, default=1.0, help="the simulator's real-time factor (0.1 to 2)")
    args = parser.parse_args()
    if not 1 <= args.runs <= 20 or not 0 <= args.stress <= 8 or not (math.isfinite(args.rtf) and
                                                                    0.1 <= args.rtf <= 2.0):
        parser.error(f"--runs 1..20, --stress 0..8 and --rtf 0.1..2 (got {args.runs}, {args.stress}, {args.rtf})")
    rows = []
    for stress in [0] + ([args.stress] if args.stress else []):
        load = f"stress {stress}" if stress else "machine"
        busy = start_stress(stress)
        try:
            for run in range(args.runs):
                with domain_lease(os.getpid() % 100, None) as domain:
                    os.environ.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
                    rows.append((load, run, swap(args.rtf)))
                print(f"{load} run {run}: {rows[-1][2]}", flush=True)
        finally:
            stop_stress(busy)
    print(f"\n{'load':10} {'run':>3} {'rtf':>4} {'robot1/2/3':32} {'swap s':>7} {'wall s':>7} {'closest m':>9} "
          f"{'longest standstill s':>20} {'collisions':>10} {'load1':>5}")
    for load, run, r in rows:
        standstill = "/".join(f"{s:.1f}" for s in r["standstill_s"])
        print(f"{load:10} {run:>3} {args.rtf:>4g} {'/'.join(r['status']):32} {r['swap_s']:>7.1f} {r['wall_s']:>7.1f} "
              f"{r['closest_m']:>9.2f} {standstill:>20} {'/'.join(map(str, r['collisions'])):>10} {r['load1']:>5}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
