"""Simulator speed: the real-time factor the simulator reaches headless, both lidars at 10 Hz.

    /work/devenv/bin/python bench/sim_speed.py [--sim-seconds 20] [--repeats 5] [--quick]

Every runner drives the same run: the lab robot in a world, a controller-like cmd_vel at 10 Hz
(0.3 m/s along the corridor, weaving
without touching the walls), odometry, ground truth and contacts read at 50 Hz, both 683-beam lidars
at 10 Hz, physics at its step rate. A runner returns the wall time of `sim_seconds` of simulated
time; RTF = sim_seconds / wall (>= 10 is the target). Set-up (URDF, world, pybullet) is not timed.

Columns, side by side in the same run:
  raw       the pure simulator loop (SimplebotSim, no ROS): the limit any node can reach.
            "rays" is the share of its time spent in the lidar ray batches.
  no lidar  the same loop with the ray casting skipped: what physics + drive + odometry cost.
A runner for the ROS simulator node is added to RUNNERS with the same signature
(Config -> wall seconds); the table then gets its column and its ratio to raw.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_description import robot_description  # noqa: E402
from simplebot_navigation.sim import SimplebotSim, load_world  # noqa: E402

CMD_PERIOD = 0.1
READ_PERIOD = 0.02


@dataclass(frozen=True)
class Config:
    world: str
    body: str
    physics_rate: float
    sim_seconds: float


def make_sim(cfg: Config) -> SimplebotSim:
    description = robot_description(cfg.body)
    return SimplebotSim(load_world(cfg.world, robot_radius=description.inscribed_radius), description,
                        physics_rate=cfg.physics_rate)


def drive(sim: SimplebotSim, sim_seconds: float) -> None:
    """The timed loop: what a simulator node does between its callbacks, minus ROS."""
    next_cmd = 0.0
    while sim.sim_time < sim_seconds - 1e-9:
        if sim.sim_time >= next_cmd - 1e-9:
            sim.set_cmd_vel(0.3, 0.3 * math.cos(sim.sim_time))
            next_cmd += CMD_PERIOD
        sim.step_until(sim.sim_time + READ_PERIOD)
        sim.odometry()
        sim.ground_truth()
        sim.collisions()
        sim.due_scans()


# Seconds spent casting rays in run_raw, per config (the "rays" column).
RAY_SECONDS: dict[Config, list[float]] = {}


def run_raw(cfg: Config) -> float:
    sim = make_sim(cfg)
    cast, ray_seconds = sim._cast, RAY_SECONDS.setdefault(cfg, [])

    def timed_cast(sensors):
        start = time.perf_counter()
        cast(sensors)
        ray_seconds.append(time.perf_counter() - start)

    sim._cast = timed_cast
    start = time.perf_counter()
    drive(sim, cfg.sim_seconds)
    wall = time.perf_counter() - start
    sim.close()
    return wall


def run_no_lidar(cfg: Config) -> float:
    sim = make_sim(cfg)
    sim._cast = lambda sensors: None
    start = time.perf_counter()
    drive(sim, cfg.sim_seconds)
    wall = time.perf_counter() - start
    sim.close()
    return wall


RUNNERS = {"raw": run_raw, "no lidar": run_no_lidar}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sim-seconds", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="5 sim seconds, 3 repeats, 100 Hz only")
    args = parser.parse_args()
    sim_seconds, repeats = (5.0, 3) if args.quick else (args.sim_seconds, args.repeats)
    rows = [("lab", "box", 100.0), ("lab", "round", 100.0)]
    if not args.quick:
        rows.append(("lab", "box", 240.0))

    print(f"{sim_seconds:g} sim s per repeat, {repeats} repeats, interleaved; RTF = sim time / wall time "
          f"(median, and p95 of wall time -> the low RTF)")
    header = f"{'world':8} {'body':6} {'physics':>8} |"
    for name in RUNNERS:
        header += f" {name + ' RTF med':>16} {'p95':>6} |"
    header += f" {'rays':>5} | ratios (median wall / raw)"
    print(header)
    print("-" * len(header))
    for world, body, rate in rows:
        cfg = Config(world, body, rate, sim_seconds)
        walls = {name: [] for name in RUNNERS}
        for _ in range(repeats):
            # Interleave the runners so machine load hits all columns alike.
            for name, runner in RUNNERS.items():
                walls[name].append(runner(cfg))
        line = f"{world:8} {body:6} {rate:>6g}Hz |"
        for name in RUNNERS:
            med, p95 = np.median(walls[name]), np.percentile(walls[name], 95)
            line += f" {sim_seconds / med:>15.1f}x {sim_seconds / p95:>5.1f}x |"
        share = sum(RAY_SECONDS[cfg]) / sum(walls["raw"])
        ratios = ", ".join(f"{name} {np.median(walls[name]) / np.median(walls['raw']):.2f}"
                           for name in RUNNERS if name != "raw")
        line += f" {share:>5.0%} | {ratios}"
        print(line)


if __name__ == "__main__":
    main()
