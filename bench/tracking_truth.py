"""The obstacle tracker against the simulator's ground truth (docs/reference.md §6).

    python bench/tracking_truth.py [--worlds crowd:hard people:0-4 ...] [--speed 1.0] [--through-contacts]
                                   [--lab] [--forest N] [--forest-speed V] [--seconds S]

Runs the in-process simulator (no ROS): both lidars of the robot go into ObstacleTracker one scan per update, as
move_base feeds it, 10 times a second, the scans taken from the lidars' true poses so that tracks and ground truth
share the world frame. Only the tracker's public API is used, so with PYTHONPATH=<other tree> the same command
measures another tree's tracker.

1. Driving through crowds (--worlds; default crowd:hard, the 10 hard crowd worlds 2, 5, ..., 29; also crowd:easy,
   crowd:medium, crowd:0-29, people:0-9, crowd:7; "none": skip): the round robot (r = 0.25 m) drives straight from
   the world's start towards its goal at --speed, steering around nothing; the run's metrics stop at its first
   contact (pushes would turn it off its line) unless --through-contacts. An obstacle is in sight when some
   lidar's beam towards its centre ends on it (field of view, range and occlusion by anything at once); a
   sighting is a stretch in sight (gaps up to 0.5 s); its verdict is the first scan with a moving track within
   0.6 m of the obstacle's centre. Columns: verdict latency p50/p90 (s) over sightings that began without a
   moving track; lost: share of sightings out of sight for good before any verdict; band: of the (obstacle,
   scan) samples in sight with 0.8-2.5 m between the robot's outline and the obstacle's, the share with a moving
   track / only a static track / no track within the gate; velocity and position errors p50/p90 of the matched
   moving tracks; tracker time per scan pair p50/p95 (ms, the first 10 pairs of a run left out).
2. False moving tracks on static structure: --lab drives the box (lab) robot at 0.4 m/s through the lab tour's
   goals in order (the lab's six rooms, routes planned by global_planner on the lab's map, followed by pure
   pursuit: walls, doors and turns in doorways); --forest N drives the round robot at --forest-speed (default
   2 m/s) through forest worlds 0..N-1 from start to exit. Every moving track there is false: the count of tracks
   reported moving, of those moving longer than 0.5 s, and their total moving time.

--seconds caps every run's simulated time (a quick look). The tables end with the worlds, the load average
(os.getloadavg) before and after, and which tracker module ran.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# This tree before the installed package, after PYTHONPATH: a tree named there (another branch's tracker) wins.
sys.path.insert(1 + len([p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]), str(ROOT))

import simplebot_navigation.testing  # noqa: E402
from simplebot_navigation.perception import tracker as tracker_module  # noqa: E402

# The bench's own modules (testing/) come from this tree whichever tree the tracker comes from: one from before
# this bench lacks them, or has older copies.
simplebot_navigation.testing.__path__.insert(0, str(ROOT / "simplebot_navigation" / "testing"))

from simplebot_navigation.sim.crowd import LEVELS, crowd_level  # noqa: E402
from simplebot_navigation.testing.tracking_runs import FOREST_COST_SCALING, FOREST_SPEED, LAB_BODY, \
    LAB_COST_SCALING, LAB_SPEED, ROUND_BODY, crowd_run, static_run  # noqa: E402
from simplebot_navigation.testing.tracking_truth import CrowdScore, FalseMotion, percentiles  # noqa: E402

#: the crowd worlds a level name stands for
CROWD_SEEDS = range(30)
WARMUP_PAIRS = 10


def world_names(spec: str) -> list[str]:
    """crowd:hard, crowd:0-29, people:3 ... as world names; ValueError naming what is wrong."""
    family, _, seeds = spec.partition(":")
    if family not in ("crowd", "people") or not seeds:
        raise ValueError(f"{spec!r}: expected crowd:<level|seed|first-last> or people:<seed|first-last>")
    if seeds in LEVELS:
        if family != "crowd":
            raise ValueError(f"{spec!r}: levels ({', '.join(LEVELS)}) are the crowd's")
        return [f"crowd:{s}" for s in CROWD_SEEDS if crowd_level(s) == seeds]
    first, _, last = seeds.partition("-")
    if not first.isdigit() or not (last or first).isdigit() or int(last or first) < int(first):
        raise ValueError(f"{spec!r}: a seed, a range first-last or a crowd level ({', '.join(LEVELS)})")
    return [f"{family}:{s}" for s in range(int(first), int(last or first) + 1)]


def _ms(runs) -> str:
    times = [t for run in runs for t in run.update_ms[WARMUP_PAIRS:]] or [t for run in runs for t in run.update_ms]
    p50, p95 = percentiles(times, (50, 95))
    return f"{p50:5.2f} {p95:5.2f}"


def _crowd_row(label: str, runs, score: CrowdScore) -> str:
    s = score.summary()
    band = s["band_share"]
    contacts = sum(r.contact_at is not None for r in runs)
    return (f"{label:12} {sum(r.seconds for r in runs):6.1f} {contacts:4d} {s['sightings']:5d} "
            f"{s['latency_s'][0]:5.2f} {s['latency_s'][1]:5.2f} {100 * s['lost_share']:5.1f} {s['band_samples']:5d} "
            f"{100 * band['moving']:5.1f} {100 * band['static']:5.1f} {100 * band['none']:5.1f} "
            f"{s['velocity_error_m_s'][0]:5.3f} {s['velocity_error_m_s'][1]:5.3f} "
            f"{s['position_error_m'][0]:5.3f} {s['position_error_m'][1]:5.3f} {_ms(runs)}")


def crowd_table(names: list[str], speed: float, seconds: float | None, through_contacts: bool):
    print(f"\n1. Driving through crowds at {speed:g} m/s, metrics "
          f"{'through contacts' if through_contacts else 'until the first contact'}")
    print(f"{'world':12} {'sim s':>6} {'hit':>4} {'sight':>5} {'lat50':>5} {'lat90':>5} {'lost%':>5} "
          f"{'band':>5} {'mov%':>5} {'sta%':>5} {'non%':>5} {'v50':>5} {'v90':>5} {'p50':>5} {'p90':>5} "
          f"{'ms50':>5} {'ms95':>5}")
    runs, total = [], CrowdScore()
    for name in names:
        run = crowd_run(name, speed, seconds, stop_at_contact=not through_contacts)
        runs.append(run)
        total.merge(run.score)
        print(_crowd_row(name, [run], run.score), flush=True)
    print(_crowd_row("all", runs, total))
    print("  lat: verdict latency (s); band: samples 0.8-2.5 m away in sight, with a moving / only a static / no "
          "track; v, p: velocity (m/s) and position (m) error; hit: runs with a contact")
    return runs, total


def _static_row(label: str, runs, motion: FalseMotion) -> str:
    s = motion.summary()
    reached = sum(r.reached for r in runs)
    contacts = sum(r.contact_at is not None for r in runs)
    return (f"{label:12} {sum(r.seconds for r in runs):7.1f} {f'{reached}/{len(runs)}':>7} {contacts:4d} "
            f"{s['moving_tracks']:6d} {s['lasting']:6d} {s['total_s']:7.1f} {_ms(runs)}")


def static_table(jobs: list[tuple[str, tuple, float, float]], seconds: float | None):
    print("\n2. False moving tracks on static structure")
    print(f"{'world':12} {'sim s':>7} {'reached':>7} {'hit':>4} {'moving':>6} {'>0.5s':>6} {'total s':>7} "
          f"{'ms50':>5} {'ms95':>5}")
    runs, total = [], FalseMotion()
    for name, body, speed, cost_scaling in jobs:
        run = static_run(name, body, speed, cost_scaling, seconds)
        runs.append(run)
        total.merge(run.score)
        print(_static_row(f"{name}", [run], run.score), flush=True)
    if len(runs) > 1:
        print(_static_row("all", runs, total))
    print("  moving: tracks ever reported moving (all false); >0.5s: of those, moving longer than 0.5 s; "
          "total s: their moving time; hit: runs with a contact")
    return runs, total


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", nargs="+", default=["crowd:hard"],
                        help="crowd:<level|seed|first-last>, people:<seed|first-last>, or none")
    parser.add_argument("--speed", type=float, default=1.0, help="the crowd runs' speed, m/s (0 < speed <= 2)")
    parser.add_argument("--through-contacts", action="store_true", help="keep measuring after the first contact")
    parser.add_argument("--lab", action="store_true", help="the lab tour, for false moving tracks")
    parser.add_argument("--forest", type=int, default=0, metavar="N", help="forest worlds 0..N-1")
    parser.add_argument("--forest-speed", type=float, default=FOREST_SPEED,
                        help=f"the forest runs' speed, m/s (0 < speed <= {FOREST_SPEED:g}; default {FOREST_SPEED:g})")
    parser.add_argument("--seconds", type=float, default=None, help="cap each run's simulated seconds")
    args = parser.parse_args(argv)
    for name, speed in (("--speed", args.speed), ("--forest-speed", args.forest_speed)):
        if not 0 < speed <= FOREST_SPEED:
            parser.error(f"{name} must be within (0, {FOREST_SPEED:g}] m/s, got {speed:g}")
    if args.forest < 0 or (args.seconds is not None and not args.seconds > 0):
        parser.error("--forest must be >= 0 and --seconds > 0")
    try:
        args.names = [] if args.worlds == ["none"] else [n for spec in args.worlds for n in world_names(spec)]
    except ValueError as err:
        parser.error(f"--worlds {err}")
    return args


def main(argv: list[str] | None = None) -> dict:
    """Run and print the tables; returns the runs by part ("crowd", "static") for the tests."""
    args = parse(argv)
    load_before = os.getloadavg()
    results = {}
    if args.names:
        results["crowd"] = crowd_table(args.names, args.speed, args.seconds, args.through_contacts)
    jobs = ([("lab", LAB_BODY, LAB_SPEED, LAB_COST_SCALING)] if args.lab else []) + \
        [(f"forest:{i}", ROUND_BODY, args.forest_speed, FOREST_COST_SCALING) for i in range(args.forest)]
    if jobs:
        results["static"] = static_table(jobs, args.seconds)
    load_after = os.getloadavg()
    print(f"\nworlds: {' '.join(args.names + [job[0] for job in jobs]) or 'none'}")
    print(f"load average (1, 5, 15 min): before {' '.join(f'{x:.2f}' for x in load_before)}, after "
          f"{' '.join(f'{x:.2f}' for x in load_after)}; {os.cpu_count()} CPUs")
    print(f"tracker: {tracker_module.__file__}")
    return results


if __name__ == "__main__":
    main()
