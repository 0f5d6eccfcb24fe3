"""How narrow a door can each body drive through? One door per run, head-on, repeated with lidar noise.

    python bench/door_sweep.py                       # box and round, 7 ratios, 5 repeats
    python bench/door_sweep.py --bodies round --ratios 1.1,1.2 --repeat 3
    python bench/door_sweep.py --bodies box --ratios 1.25 --approach along-wall --tight

For every body and door ratio (door width / robot width 0.6 m) the `doors` world generator builds a
single-door world (hall, door, bay); the robot starts 1.5 m in front of the door and the goal is
2 m behind it. With --approach along-wall the hall is 5 m wide and the robot starts 1.8 m to the side of
the door, parallel to its wall with 0.25 m to spare, so it has to turn 90 degrees into the door: a box
must swing out first. Each repeat uses its own seed, so the Gaussian range noise makes the runs differ. The
box body runs the lab's files unchanged, the round body adds ``config/round/``, --tight adds
``config/tight/`` (the narrow-door parameter set) to either. The tightest reliable
ratio of a body is the smallest ratio from which on every wider door succeeded in every repeat.
"""

import argparse
import dataclasses
import json
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from simplebot_navigation.scenarios.report import summary  # noqa: E402
from simplebot_navigation.scenarios.runner import ScenarioOptions, run_scenarios  # noqa: E402
from simplebot_navigation.sim.world import Pose2D, write_world  # noqa: E402
from simplebot_navigation.sim.world_gen import door_goal_name, doors_world  # noqa: E402

ROBOT_WIDTH = 0.6
ALONG_WALL_START = Pose2D(-1.8, -0.6, 0.0)       # 0.25 m from its side to the door wall, 0.15 m behind it


def door_world(ratio: float, approach: str):
    """The one-door world of a sweep row; along-wall: a wider hall and a start beside the door, parallel to it."""
    if approach == "head-on":
        return doors_world(ROBOT_WIDTH, ratios=(ratio,))
    return dataclasses.replace(doors_world(ROBOT_WIDTH, ratios=(ratio,), bay_width=5.0), start=ALONG_WALL_START)


def tightest_reliable(rows: list[dict]) -> float | None:
    """Smallest ratio such that it and every wider door succeeded in every repeat."""
    best = None
    for row in sorted(rows, key=lambda r: -r["ratio"]):
        if row["succeeded"] < row["goals"]:
            break
        best = row["ratio"]
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bodies", default="box,round")
    parser.add_argument("--ratios", default="1.1,1.2,1.25,1.3,1.4,1.5,2.0")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--range-noise", type=float, default=0.01, help="lidar range noise std (m)")
    parser.add_argument("--tight", action="store_true", help="the narrow-door parameter set (config/tight/)")
    parser.add_argument("--approach", choices=("head-on", "along-wall"), default="head-on",
                        help="start in front of the door, or beside it along its wall (a 90 degree turn in)")
    parser.add_argument("--no-collision-monitor", action="store_true",
                        help="without the collision monitor (move_base drives the base directly)")
    parser.add_argument("--json", help="write the table as JSON here")
    args = parser.parse_args()
    bodies = args.bodies.split(",")
    ratios = sorted(float(r) for r in args.ratios.split(","))
    folder = tempfile.mkdtemp(prefix="door_sweep_")
    rows = []
    for body in bodies:
        for ratio in ratios:
            path = os.path.join(folder, f"door_{ratio:g}.yaml")
            write_world(door_world(ratio, args.approach), path,
                        f"one door, {ratio:g} x {ROBOT_WIDTH} m, approach {args.approach}")
            options = ScenarioOptions(world=path, robot=body, goals=door_goal_name(ratio), repeat=args.repeat,
                                      range_noise=args.range_noise, wall_timeout_s=600.0, tight=args.tight,
                                      collision_monitor=not args.no_collision_monitor)
            results, _ = run_scenarios(options, progress=lambda line: print("  " + line, flush=True))
            row = {"body": body, "approach": args.approach, "ratio": ratio, "width_m": round(ratio * ROBOT_WIDTH, 3), **summary(results)}
            rows.append(row)
            print(f"{body:>5} {ratio:>5.2f}x {row['width_m']:.3f} m: {row['succeeded']}/{row['goals']}", flush=True)
    print()
    print(f"{'body':>5}  {'ratio':>5}  {'door m':>6}  {'success':>7}  {'mean time s':>11}  {'collisions':>10}  "
          f"{'min clearance m':>15}  {'recoveries':>10}")
    for row in rows:
        print(f"{row['body']:>5}  {row['ratio']:>5.2f}  {row['width_m']:>6.3f}  "
              f"{row['succeeded']:>3}/{row['goals']:<3}  {row['mean_time_s']:>11.1f}  {row['collisions']:>10}  "
              f"{row['min_clearance']:>15.2f}  {row['recoveries']:>10}")
    for body in bodies:
        best = tightest_reliable([r for r in rows if r["body"] == body])
        print(f"tightest reliable door for {body}: " + (f"{best:g} x its width" if best else "none of these"))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
