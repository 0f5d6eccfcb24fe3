"""SLAM against the truth: the mapper on scripted drives through the lab and around the office's corridor loop, with
the launch's drifting encoders, side by side with odometry alone.

    python bench/slam.py [--drives lab,office] [--seeds 0,1,2] [--speed 1.0] [--save-maps DIR]

Each drive runs the pure mapper (slam.Mapper with config/slam/slam.yaml, as navigation slam:=true runs it) on the
simulator without ROS: the robot follows a route planned on the world's map by pure pursuit on the true pose, so every
configuration sees the same drive. ``lab`` is the lab tour (its six goals, then back to the start), ``office`` the
corridor loop round the block (101 m) and on past the start to the kitchen. Per drive and seed it prints:

  ATE          the RMS position error of the nodes against the truth (no alignment: the map frame is the world's)
  odometry     the same for the wheel odometry's poses
  precision    the map's occupied cells within a cell (0.05 m) of a true obstacle of the world's map
  recall       the walls the scans saw, drawn at the true poses, that the map has within a cell
  doubled      blobs of at least 10 occupied cells more than a cell from every true obstacle: walls drawn twice
  closures     loop closures accepted
  mapper       the mapper's time (every add_scan, wall clock) over the drive's simulated time: its share of a core
               in real time at this speed
  match p95    the 95th percentile of add_scan's wall time over the scans that became nodes (matching)
  worst        the longest add_scan: a loop closure's optimisation and the map drawn again
  optimise     gtsam's Levenberg-Marquardt on a 1000-node graph with 100 loop edges (once per run, median of 5)

Lines "odometry only" are the same drive with use_scan_matching and do_loop_closing off: the map odometry alone
draws. ``--save-maps DIR`` writes each slam map as DIR/<drive>_<seed>.yaml + .pgm (map_server's format), to navigate
on: ``python -m simplebot_navigation.scenarios --world lab --map DIR/lab_0.yaml``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.maps.map_io import save_map  # noqa: E402
from simplebot_navigation.sim.world import Pose2D  # noqa: E402
from simplebot_navigation.sim.world_loader import load_world  # noqa: E402
from simplebot_navigation.slam.pose_graph import PoseGraph  # noqa: E402
from simplebot_navigation.testing.proc_stats import loadavg  # noqa: E402
from simplebot_navigation.testing.slam_drive import configured_params, drive, map_score, trajectory_rmse  # noqa: E402


def routes() -> dict[str, tuple[str, list[Pose2D]]]:
    lab, office = load_world("lab"), load_world("office")
    loop = [office.goal("corridor_se"), office.goal("corridor_ne"), office.goal("corridor_nw"),
            Pose2D(office.start.x, office.start.y, 0.0, "start"), office.goal("kitchen")]
    return {"lab": ("lab", [*lab.goals, lab.start]), "office": ("office", loop)}


def one(world_name: str, goals: list[Pose2D], seed: int, speed: float, odometry_only: bool,
        save_as: Path | None = None) -> dict:
    world = load_world(world_name)
    overrides = {"use_scan_matching": False, "do_loop_closing": False} if odometry_only else {}
    run = drive(world, goals, configured_params(**overrides), speed=speed, seed=seed)
    mapper = run.mapper
    score = map_score(mapper.occupancy_map(), world, run)
    if save_as is not None:
        save_map(mapper.occupancy_map(), save_as, "trinary", 0.65, 0.25)
    node_times = np.array(run.add_scan_s) * 1e3
    return {"reached": run.reached, "sim_s": run.sim_time, "nodes": len(mapper.scans),
            "ate": trajectory_rmse(mapper.graph.poses, run.truth), "odom": trajectory_rmse(run.odometry, run.truth),
            "precision": score.precision, "recall": score.recall, "doubled": score.doubled_walls,
            "closures": sum(e.kind == "loop" for e in mapper.graph.edges),
            "cpu": sum(run.add_scan_s) / max(run.sim_time, 1e-9), "p95": float(np.percentile(node_times, 95)),
            "worst": float(node_times.max())}


def optimisation_ms(nodes: int = 1000, loops: int = 100) -> float:
    """gtsam on a chain of ``nodes`` with ``loops`` closures, as a long session's graph is (median of 5, ms)."""
    rng = np.random.default_rng(0)
    times = []
    for _ in range(5):
        graph = PoseGraph()
        pose = (0.0, 0.0, 0.0)
        graph.add_node(pose)
        step = np.diag([0.02 ** 2, 0.02 ** 2, 0.01 ** 2])
        for i in range(1, nodes):
            turn = 2 * math.pi / 200
            pose = (pose[0] + 0.5 * math.cos(pose[2]), pose[1] + 0.5 * math.sin(pose[2]), pose[2] + turn)
            graph.add_node((pose[0] + rng.normal(0, 0.1), pose[1] + rng.normal(0, 0.1), pose[2]))
            graph.add_edge(i - 1, i, (0.5, 0.0, turn), step, "scan")
        for k in range(loops):
            i = int(rng.integers(0, nodes - 200))
            graph.add_edge(i, i + 200, (0.0, 0.0, 0.0), step, "loop")
        began = time.perf_counter()
        graph.optimize()
        times.append((time.perf_counter() - began) * 1e3)
    return float(np.median(times))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", default="lab,office")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--speed", type=float, default=1.0)
    parser.add_argument("--save-maps", type=Path, help="a folder for the slam maps (map_server YAML + PGM)")
    args = parser.parse_args()
    table = routes()
    seeds = [int(s) for s in args.seeds.split(",")]
    if args.save_maps is not None:
        args.save_maps.mkdir(parents=True, exist_ok=True)
    print(f"# bench/slam.py --drives {args.drives} --seeds {args.seeds} --speed {args.speed:g}   "
          f"load {loadavg()}   cores {os.cpu_count()}")
    print("| drive | seed | mapping | reached | nodes | ATE m | odometry m | precision | recall | doubled | closures | "
          "mapper | match p95 ms | worst ms |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.drives.split(","):
        world_name, goals = table[name]
        for seed in seeds:
            for odometry_only in (False, True):
                save_as = (args.save_maps / f"{name}_{seed}.yaml" if args.save_maps is not None and not odometry_only
                           else None)
                r = one(world_name, goals, seed, args.speed, odometry_only, save_as)
                label = "odometry only" if odometry_only else "slam"
                print(f"| {name} | {seed} | {label} | {r['reached']} | {r['nodes']} | {r['ate']:.3f} | "
                      f"{r['odom']:.2f} | {r['precision']:.3f} | {r['recall']:.3f} | {r['doubled']} | "
                      f"{r['closures']} | {r['cpu']:.1%} | {r['p95']:.1f} | {r['worst']:.0f} |", flush=True)
    print(f"\noptimisation of 1000 nodes and 100 loop edges: {optimisation_ms():.0f} ms (median of 5)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
