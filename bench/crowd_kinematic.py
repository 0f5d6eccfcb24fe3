"""The local planner alone among a world's true obstacle motion: kinematic crowd runs (testing/crowd_drive.py).

    python bench/crowd_kinematic.py [--worlds people:0-11,crowd:0-29] [--speed 1.0] [--set K=V ...] [--jobs 2]
                                    [--out runs.jsonl] [--oracle] [--true-future]

Each world is driven closed loop by the MPPI controller a campaign's ``tight max_speed=V
base_local_planner=mppi_local_planner/MPPILocalPlannerROS`` line builds (``--set`` overrides its parameters, flat
names), on the diff drive's wheel ramp, with every moving obstacle within the lidars' range known exactly, and no
physics, lidar, tracker or ROS: a world takes seconds, not minutes. The table gives per level success, collisions
while moving, struck while standing, the median time to the success radius, the decisions the passive safety took
and the cycle's p50 / p95; ``--oracle`` adds the omniscient space-time search's answer (bench/space_time_oracle.py)
beside it. ``--true-future`` hands the planner where every obstacle will truly be instead of its constant-velocity
prediction: what a perfect predictor would give this planner. The last line is the load average before and after.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.scenarios.campaign.spec import expand_worlds, world_family  # noqa: E402
from simplebot_navigation.sim.world_loader import load_world  # noqa: E402
from simplebot_navigation.testing.crowd_drive import drive, mppi_setup  # noqa: E402


def _value(text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def run_one(job: tuple[str, float, dict, bool, bool]) -> dict:
    name, speed, overrides, with_oracle, true_future = job
    world = load_world(name)
    result = drive(world, mppi_setup(speed, overrides=overrides), speed, clock=time.perf_counter,
                   true_future=true_future)
    first = next((c for c in result.contacts if c.kind == "moving"), None)
    record = {"world": name, "level": world.extra.get("level", world_family(name)), "success": result.success,
              "arrived_s": result.arrived_s if math.isfinite(result.arrived_s) else None,
              "moving": result.moving_collisions, "standing": result.struck_standing, "kinds": result.kinds,
              "end_distance": round(result.end_distance, 2),
              "first_contact": None if first is None else {"t": first.t, "what": first.what,
                                                           "speed": round(first.speed, 2),
                                                           "pose": [round(p, 2) for p in first.pose]},
              "cycle_ms": sorted(round(1e3 * s, 2) for s in result.cycle_s[5:])}
    if with_oracle:
        sys.path.insert(0, str(ROOT / "bench"))
        from space_time_oracle import oracle
        answer = oracle(name, world, speed, 0.0)
        record["oracle_s"] = answer.get("arrival_s")
    return record


def _percentile(values: list[float], share: float) -> float:
    return values[min(len(values) - 1, int(share * len(values)))] if values else math.nan


def table(records: list[dict], oracle: bool) -> str:
    levels = sorted({r["level"] for r in records}, key=lambda level: ("easy", "medium", "hard").index(level)
                    if level in ("easy", "medium", "hard") else 3)
    header = "| level | success | moving collisions | struck standing | median arrival s | decisions | cycle p50 / p95 ms |"
    if oracle:
        header += " oracle solves | oracle median arrival s |"
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for level in levels + ["all"]:
        rows = [r for r in records if level in ("all", r["level"])]
        won = [r for r in rows if r["success"]]
        kinds: dict[str, int] = {}
        for r in rows:
            for kind, count in r["kinds"].items():
                kinds[kind] = kinds.get(kind, 0) + count
        total = sum(kinds.values()) or 1
        shares = ", ".join(f"{kind} {100 * count / total:.0f} %" for kind, count in sorted(kinds.items(),
                                                                                             key=lambda kv: -kv[1]))
        cycles = sorted(c for r in rows for c in r["cycle_ms"])
        arrival = statistics.median([r["arrived_s"] for r in won]) if won else math.nan
        line = (f"| {level} | {len(won)}/{len(rows)} | {sum(r['moving'] for r in rows)} | "
                f"{sum(r['standing'] for r in rows)} | {arrival:.1f} | {shares} | "
                f"{_percentile(cycles, 0.5):.1f} / {_percentile(cycles, 0.95):.1f} |")
        if oracle:
            solved = [r["oracle_s"] for r in rows if r.get("oracle_s") is not None]
            line += f" {len(solved)}/{len(rows)} | {statistics.median(solved) if solved else math.nan:.1f} |"
        lines.append(line)
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--worlds", default="people:0-11,crowd:0-29")
    parser.add_argument("--speed", type=float, default=1.0)
    parser.add_argument("--set", action="append", default=[], metavar="K=V", help="an MPPI parameter (flat name)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--oracle", action="store_true", help="the omniscient search's answer beside each level")
    parser.add_argument("--true-future", action="store_true",
                        help="the planner knows where every obstacle will be (prediction's limit)")
    args = parser.parse_args()
    overrides = {}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = _value(value)
    names = expand_worlds([w for w in args.worlds.split(",") if w])
    load = os.getloadavg()[0]
    jobs = [(name, args.speed, overrides, args.oracle, args.true_future) for name in names]
    records = []
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for record in pool.map(run_one, jobs):
            records.append(record)
            first = record["first_contact"]
            print(f"{record['world']}: {'ok' if record['success'] else 'FAIL'} arrived {record['arrived_s']} "
                  f"moving {record['moving']} standing {record['standing']}"
                  + (f" first {first}" if first else ""), file=sys.stderr, flush=True)
            if args.out:
                with args.out.open("a") as f:
                    f.write(json.dumps({k: v for k, v in record.items() if k != "cycle_ms"}) + "\n")
    print(f"speed {args.speed} m/s, overrides {overrides or 'none'}, prediction "
          f"{'the true future' if args.true_future else 'constant velocity'}")
    print(table(records, args.oracle))
    print(f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
