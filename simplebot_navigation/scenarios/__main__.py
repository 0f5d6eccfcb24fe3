"""python -m simplebot_navigation.scenarios [campaign ...] [--world lab] [--robot box|round] [--goals ...] [--json out.json]

Runs the simulator and move_base of the navigation launch file in this process (lockstep by
default: as fast as the nodes allow, and the same seed gives the same run), sends each goal through
the move_base action and prints a line per goal and a table. Exit code 0 if every goal succeeded,
1 if one did not, 2 for bad arguments.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

from simplebot_description import builtin_worlds, robot_description
from simplebot_navigation.launch.loader import LaunchError
from simplebot_navigation.launch.nodes import ExecutableNotFound
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.move_base.speed_profile import check_speed
from simplebot_navigation.scenarios.report import plot, table, write_json
from simplebot_navigation.scenarios.runner import ScenarioOptions, parse_goals, run_scenarios


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m simplebot_navigation.scenarios",
                                description=__doc__.split("\n\n")[1].replace("\n", " "))
    p.add_argument("--world", default="lab",
                   help=f"built-in world ({', '.join(builtin_worlds())}), forest:<seed> or a world/map YAML "
                        "path; 'clutter' and 'forest' are regenerated for each run's seed (default: lab)")
    p.add_argument("--robot", default="box", choices=("box", "round"), help="robot body (default: box)")
    p.add_argument("--radius", type=float, default=0.3, help="radius of the round body in metres (default: 0.3)")
    p.add_argument("--tight", action="store_true",
                   help="the narrow-door parameter set (config/tight/) over the lab's files")
    p.add_argument("--goals", help="'x,y,yaw;x,y,yaw' in the world frame and/or goal names of the world "
                                   "('nw_office,library'); default: every goal of the world file")
    p.add_argument("--rtf", type=float, default=0.0,
                   help="real-time factor; 0 = lockstep, as fast as the nodes allow (default: 0)")
    p.add_argument("--processes", action="store_true",
                   help="run the launcher's processes (needs --rtf > 0) instead of the nodes in this process; "
                        "replans, recoveries and cycle times are then not available")
    p.add_argument("--repeat", type=int, default=1, help="run the whole scenario N times (default: 1)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first run; run i uses seed + i (default: 0)")
    p.add_argument("--range-noise", type=float, default=0.0,
                   help="standard deviation of the lidar range noise in metres (default: 0)")
    p.add_argument("--time-budget", type=float,
                   help="sim seconds per goal (default: 20 s + 2 x shortest path / max_vel_x)")
    p.add_argument("--max-speed", type=float, metavar="V",
                   help="top speed in m/s, from which every speed-dependent move_base parameter is derived, and the "
                        "drive (docs/reference.md §10; --set wins over what it derives)")
    p.add_argument("--wall-timeout", type=float, help="wall-clock seconds per goal before giving up on a hang")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a move_base parameter by its ROS 2 name, e.g. TebLocalPlannerROS.max_vel_x=1.0 (repeatable)")
    p.add_argument("--foxglove", action="store_true",
                   help="serve every topic to the Foxglove app on ws://127.0.0.1:PORT "
                        "(layout: config/simplebot.foxglove.json)")
    p.add_argument("--foxglove-port", type=int, default=8766, metavar="PORT",
                   help="port of the Foxglove WebSocket server (default: 8766; 0: a free one)")
    p.add_argument("--no-moving-obstacles", action="store_true",
                   help="track and predict nothing (the launch files' moving_obstacles:=false): every obstacle is a "
                        "costmap mark")
    p.add_argument("--true-obstacles", action="store_true",
                   help="move_base gets the simulator's true moving obstacles within the lidars' range instead of its "
                        "tracker's (perception's limit; in-process runs only)")
    p.add_argument("--no-collision-monitor", action="store_true",
                   help="run without the collision monitor: move_base drives the base directly")
    p.add_argument("--map", metavar="MAP",
                   help="navigate on a map, localized by amcl, with drifting encoders: 'world' (the map of each "
                        "run's world) or a map_server YAML; reports amcl's error against ground truth")
    p.add_argument("--json", metavar="OUT.json", help="write the results as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="draw the trajectories over the world (matplotlib PNG)")
    return p


def _check(parser: argparse.ArgumentParser, args: argparse.Namespace) -> ScenarioOptions:
    """Every argument checked before a node starts, each error naming the option."""
    positive = {"--radius": args.radius, "--time-budget": args.time_budget, "--wall-timeout": args.wall_timeout}
    for name, value in positive.items():
        if value is not None and not (math.isfinite(value) and value > 0):
            parser.error(f"{name} must be a positive number, got {value}")
    for name, value in {"--rtf": args.rtf, "--range-noise": args.range_noise}.items():
        if not (math.isfinite(value) and value >= 0):
            parser.error(f"{name} must be >= 0, got {value}")
    if args.processes and args.rtf == 0:
        parser.error("--processes needs --rtf > 0 (lockstep runs the nodes in this process)")
    if args.repeat < 1:
        parser.error(f"--repeat must be >= 1, got {args.repeat}")
    if not 0 <= args.foxglove_port <= 65535:
        parser.error(f"--foxglove-port must be 0..65535, got {args.foxglove_port}")
    if args.map not in (None, "world") and not (args.map.lower().endswith((".yaml", ".yml"))
                                               and os.path.isfile(args.map)):
        parser.error(f"--map {args.map}: neither 'world' nor an existing map YAML file")
    for option, path in (("--json", args.json), ("--plot", args.plot)):
        folder = os.path.dirname(os.path.abspath(path)) if path else None
        if folder and not os.path.isdir(folder):
            parser.error(f"{option} {path}: directory {folder} does not exist")
    try:
        description = robot_description(args.robot, args.radius)
        world = load_world(args.world, robot_radius=description.inscribed_radius)
        parse_goals(args.goals, world)
    except (ValueError, FileNotFoundError) as err:
        parser.error(str(err))
    for warning in world.warnings:
        print(f"scenario: warning: {warning}", file=sys.stderr)
    if args.true_obstacles and args.processes:
        parser.error("--true-obstacles: the simulator's obstacles reach move_base only in-process (not with --processes)")
    if args.true_obstacles and args.no_moving_obstacles:
        parser.error("--true-obstacles replaces the tracker: not with --no-moving-obstacles")
    if args.max_speed is not None and check_speed(args.max_speed):
        parser.error(check_speed(args.max_speed))
    return ScenarioOptions(world=args.world, robot=args.robot, radius=args.radius, goals=args.goals, rtf=args.rtf,
                           repeat=args.repeat, seed=args.seed, range_noise=args.range_noise,
                           time_budget=args.time_budget, processes=args.processes, tight=args.tight,
                           wall_timeout_s=args.wall_timeout, overrides=tuple(args.set),
                           foxglove_port=args.foxglove_port if args.foxglove else None,
                           collision_monitor=not args.no_collision_monitor, map_name=args.map or "",
                           max_speed=args.max_speed, moving_obstacles=not args.no_moving_obstacles,
                           true_obstacles=args.true_obstacles)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["campaign"]:
        from simplebot_navigation.scenarios.campaign.cli import main as campaign_main

        return campaign_main(argv[1:])
    parser = _parser()
    args = parser.parse_args(argv)
    options = _check(parser, args)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    mode = "lockstep" if options.rtf == 0 else f"real-time factor {options.rtf:g}" + (
        ", separate processes" if options.processes else "")
    print(f"scenario: world {options.world}, {options.robot} robot, {mode}, {options.repeat} run(s) from seed "
          f"{options.seed}", flush=True)
    try:
        results, worlds = run_scenarios(options, progress=lambda line: print(line, flush=True))
    except (LaunchError, ExecutableNotFound) as err:
        print(f"scenarios: error: {err}", file=sys.stderr)
        return 2
    print()
    print(table(results))
    if args.json:
        write_json(args.json, options, results)
        print(f"results written to {args.json}")
    if args.plot:
        same_world = all(w == worlds[0] for w in worlds)
        shown = results if same_world else [r for r in results if r.run == 0]
        ok = sum(r.success for r in shown)
        plot(args.plot, worlds[0], shown,
             f"{worlds[0].name}, {options.robot} robot: {ok}/{len(shown)} goals"
             + ("" if same_world else f" (run 1 of {options.repeat}, seed {options.seed})"))
        print(f"trajectories drawn in {args.plot}")
    return 0 if all(r.success for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
