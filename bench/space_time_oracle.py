"""The limit of the moving-obstacle worlds: an omniscient space-time search over each world's true obstacle motion.

    python bench/space_time_oracle.py [--worlds crowd:0-149,people:0-29] [--speed 1.0] [--clearance 0.0]
                                      [--campaign runs.jsonl ...] [--out oracle.jsonl]

For every world, planning/space_time.py grows the set of places the robot's centre can be at each step (the round
body, r = 0.25 m, holonomic at --speed, waiting allowed), among the static world and the obstacles where they
truly are at every step, from the world's start at the time a campaign sends its goal (the session's warm-up),
staying --clearance m beyond every obstacle. It reports whether the goal region (the world's success radius) is
reached within the world's time budget, and the earliest arrival: a lower bound on any run's time to goal, and
with "no", a world no planner of that speed and clearance gets through.

--campaign reads campaign records (scenarios campaign --out) of the same worlds at the same max_speed and puts
each level's success beside the oracle's: success of solvable worlds, and the median ratio of a successful run's
time to the oracle's arrival. The table ends with the load average before and after.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.planning.space_time import MovingDiscs, SpaceTimeSearch  # noqa: E402
from simplebot_navigation.scenarios.campaign.spec import expand_worlds, world_family  # noqa: E402
from simplebot_navigation.scenarios.session import WARM_UP_S  # noqa: E402
from simplebot_navigation.sim.crowd import LEVELS  # noqa: E402
from simplebot_navigation.sim.cspace import static_free  # noqa: E402
from simplebot_navigation.sim.moving import MovingTracks  # noqa: E402
from simplebot_navigation.sim.world_loader import load_world  # noqa: E402

ROBOT_RADIUS = 0.25
RESOLUTION = 0.05
DEFAULT_BUDGET_S = 100.0
DEFAULT_SUCCESS_RADIUS = 0.5


def oracle(world_name: str, world, speed: float, clearance: float) -> dict:
    """One world's answer: solvable, arrival (s after the goal is sent), and the search's own time."""
    started = time.perf_counter()
    goal = world.goals[0]
    free, origin = static_free(world, ROBOT_RADIUS + clearance, RESOLUTION)
    search = SpaceTimeSearch(free, origin, RESOLUTION)
    tracks = MovingTracks(world.moving)
    radii = tracks.reach + ROBOT_RADIUS

    def discs_at(t: float) -> MovingDiscs:
        states = tracks.states(t)
        return MovingDiscs(states[:, :2], radii, (states[:, 2] ** 2 + states[:, 3] ** 2) ** 0.5)

    budget = float(world.extra.get("time_budget", DEFAULT_BUDGET_S))
    radius = float(world.extra.get("success_radius", DEFAULT_SUCCESS_RADIUS))
    arrival = search.earliest_arrival((world.start.x, world.start.y), (goal.x, goal.y), radius, speed, discs_at,
                                      WARM_UP_S, budget, clearance)
    return {"world": world_name, "family": world_family(world_name), "speed": speed, "clearance": clearance,
            "solvable": arrival.solvable, "arrival_s": arrival.arrival_s - WARM_UP_S if arrival.solvable else None,
            "straight_s": math.hypot(goal.x - world.start.x, goal.y - world.start.y) / speed,
            "search_s": time.perf_counter() - started}


def campaign_runs(paths: list[str], speed: float) -> dict[str, dict]:
    """The latest record per world at this max_speed."""
    runs = {}
    for path in paths:
        with open(path) as f:
            for line in f:
                record = json.loads(line)
                if "world" in record and abs(float(record.get("max_vel_x") or 0) - speed) < 1e-6:
                    runs[record["world"]] = record
    return runs


def table(results: list[dict], runs: dict[str, dict]) -> list[str]:
    order = [f"crowd {level}" for level in LEVELS]
    families = sorted({r["family"] for r in results}, key=lambda f: (order.index(f) if f in order else len(order), f))
    head = "| worlds | n | oracle: solvable | oracle: arrival p50 (straight line) |"
    if runs:
        head += " runs | success | success of solvable | run time / oracle p50 |"
    lines = [head, "|" + "---|" * head.count(" |")]
    for family in families:
        rows = [r for r in results if r["family"] == family]
        solvable = [r for r in rows if r["solvable"]]
        arrivals = [r["arrival_s"] for r in solvable]
        line = (f"| {family} | {len(rows)} | {len(solvable)}/{len(rows)} | "
                f"{statistics.median(arrivals):.1f} s ({statistics.median(r['straight_s'] for r in rows):.1f} s) |"
                if arrivals else f"| {family} | {len(rows)} | 0/{len(rows)} | - |")
        if runs:
            ran = [r for r in rows if r["world"] in runs]
            won = [r for r in ran if runs[r["world"]]["success"]]
            ratios = [runs[r["world"]]["time_s"] / r["arrival_s"] for r in won if r["solvable"]]
            line += (f" {len(ran)} | {len(won)}/{len(ran)} | {sum(r['solvable'] for r in won)}/"
                     f"{sum(r['solvable'] for r in ran)} | {statistics.median(ratios):.2f} |" if ratios
                     else f" {len(ran)} | {len(won)}/{len(ran)} | - | - |")
        lines.append(line)
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", default="crowd:0-149,people:0-29", help="comma-separated, ranges as first-last")
    parser.add_argument("--speed", type=float, default=1.0, help="the robot's top speed, m/s (campaign max_speed)")
    parser.add_argument("--clearance", type=float, default=0.0, help="extra distance kept from every obstacle, m")
    parser.add_argument("--campaign", action="append", default=[], help="campaign records to compare (jsonl)")
    parser.add_argument("--out", help="write one JSON line per world here")
    args = parser.parse_args(argv)
    if not (0 < args.speed <= 5.0) or not (0 <= args.clearance <= 2.0):
        parser.error("--speed must be in (0, 5] m/s and --clearance in [0, 2] m")
    try:
        names = expand_worlds(args.worlds.split(","))
        worlds = {name: load_world(name) for name in names}
    except ValueError as err:
        parser.error(f"--worlds: {err}")
    if any(not world.goals for world in worlds.values()):
        parser.error(f"--worlds: {', '.join(n for n, w in worlds.items() if not w.goals)} has no goal")
    try:
        runs = campaign_runs(args.campaign, args.speed)
    except (OSError, ValueError) as err:      # a missing file, a line that is not JSON
        parser.error(f"--campaign: {err}")
    load_before = os.getloadavg()[0]
    results = []
    for name in names:
        results.append(oracle(name, worlds[name], args.speed, args.clearance))
        r = results[-1]
        print(f"{name}: {'solvable, arrival %.1f s' % r['arrival_s'] if r['solvable'] else 'NOT solvable'} "
              f"(search {r['search_s']:.1f} s)", flush=True)
    if args.out:
        Path(args.out).write_text("".join(json.dumps(r) + "\n" for r in results))
    print(f"\nspeed {args.speed:g} m/s, round body r = {ROBOT_RADIUS} m, clearance {args.clearance:g} m, "
          f"grid {RESOLUTION} m")
    print("\n".join(table(results, runs)))
    print(f"\nsearch time per world p50 {statistics.median(r['search_s'] for r in results):.1f} s; "
          f"load average {load_before:.1f} before, {os.getloadavg()[0]:.1f} after")
    return 0


if __name__ == "__main__":
    sys.exit(main())
