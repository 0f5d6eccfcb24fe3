"""MPPI's control cycle among moving obstacles, with and without its space-time guide (docs/reference.md §4.10).

    python bench/mppi_guide.py [--cycles N] [--obstacles K]

The round body (r = 0.25) drives along a straight plan at the speed setting's vx_max (1 and 2 m/s) through K
obstacles of radius 0.5 walking straight at 0.5-1.9 m/s around it, the local costmap a 5 x 5 m window at 0.025 m
with a wall along one side. Each cycle moves the robot by its own command (kinematically) and the obstacles by
their velocity; the controller is the pure MppiController, as move_base calls it. Prints per configuration the
cycle's p50 / p95 / max in ms, the share of one core at 20 Hz, and the guide's own search p50 / p95 / max per
replan (it runs every guide_period, 0.1 s: every second cycle).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.costmap.costmap_2d import Costmap2D  # noqa: E402
from simplebot_navigation.costmap.footprint import footprint_from_radius  # noqa: E402
from simplebot_navigation.mppi import MppiConfig, MppiController, warm_up  # noqa: E402
from simplebot_navigation.mppi.plugin import speed_parameters  # noqa: E402

PERIOD = 0.05
WARMUP = 10
RADIUS = 0.25


def scene(count: int, rng: np.random.Generator) -> np.ndarray:
    """(K, 5) x, y, vx, vy, radius: obstacles within 7 m of the start, none within 1.5 m of it."""
    rows = []
    while len(rows) < count:
        x, y = rng.uniform([-3.0, -7.0], [11.0, 7.0])
        if math.hypot(x, y) < 1.5:
            continue
        heading, speed = rng.uniform(-math.pi, math.pi), rng.uniform(0.5, 1.9)
        rows.append((x, y, speed * math.cos(heading), speed * math.sin(heading), 0.5))
    return np.array(rows)


def costmap_at(x: float, y: float) -> Costmap2D:
    """The rolling window around (x, y), a wall at y = -2.2 (inflated by nothing: lethal cells only)."""
    costmap = Costmap2D(200, 200, 0.025, x - 2.5, y - 2.5)
    rows = np.floor((-2.2 - costmap.origin_y) / costmap.resolution).astype(int)
    if 0 <= rows < costmap.costmap.shape[0]:
        costmap.costmap[:rows + 1, :] = 254
    return costmap


def run(speed: float, guide: bool, cycles: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    params = {**speed_parameters(speed), "space_time_guide": guide}
    cfg = MppiConfig.from_params(params)
    controller = MppiController(cfg, footprint_from_radius(RADIUS), PERIOD)
    plan = np.column_stack([np.linspace(0.0, 60.0, 601), np.zeros(601), np.zeros(601)])
    controller.set_plan(plan)
    rng = np.random.default_rng(7)
    obstacles = scene(count, rng)
    state = np.zeros(5)
    cycle_ms, search_ms = [], []
    plan_guide = controller.guide.plan

    def timed_plan(*args, **kwargs):
        start = time.perf_counter()
        out = plan_guide(*args, **kwargs)
        search_ms.append(1e3 * (time.perf_counter() - start))
        return out
    controller.guide.plan = timed_plan
    for k in range(cycles + WARMUP):
        controller.set_dynamic_obstacles(obstacles)
        start = time.perf_counter()
        result = controller.compute_velocity_commands(state[:3], state[3:], costmap_at(state[0], state[1]))
        if k >= WARMUP:
            cycle_ms.append(1e3 * (time.perf_counter() - start))
        v, w = (result.v, result.omega) if result.ok else (0.0, 0.0)
        state[2] += w * PERIOD
        state[0] += v * PERIOD * math.cos(state[2])
        state[1] += v * PERIOD * math.sin(state[2])
        state[3:] = v, w
        obstacles[:, :2] += PERIOD * obstacles[:, 2:4]
        far = np.hypot(*(obstacles[:, :2] - state[:2]).T) > 9.0      # walk back in from the other side
        obstacles[far, :2] = state[:2] + (state[:2] - obstacles[far, :2]) * 0.75
        if state[0] > 50.0:
            state[:] = 0.0
            controller.set_plan(plan)
    return np.array(cycle_ms), np.array(search_ms[WARMUP // 2:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=400)
    parser.add_argument("--obstacles", type=int, default=24)
    args = parser.parse_args()
    if not 1 <= args.cycles <= 100_000 or not 0 <= args.obstacles <= 200:
        parser.error("--cycles must be 1..100000 and --obstacles 0..200")
    warm_up()
    print(f"{args.obstacles} obstacles, {args.cycles} cycles each")
    print("| vx_max | guide | cycle p50 | p95 | max | core at 20 Hz | search p50 | p95 | max |")
    print("|---|---|---|---|---|---|---|---|---|")
    for speed in (1.0, 2.0):
        for guide in (False, True):
            cycle, search = run(speed, guide, args.cycles, args.obstacles)
            row = f"| {speed:g} m/s | {'on' if guide else 'off'} | {np.median(cycle):.1f} ms | " \
                  f"{np.percentile(cycle, 95):.1f} ms | {cycle.max():.1f} ms | {100 * cycle.mean() / 1e3 / PERIOD:.0f} % |"
            if len(search):
                row += f" {np.median(search):.1f} ms | {np.percentile(search, 95):.1f} ms | {search.max():.1f} ms |"
            else:
                row += " - | - | - |"
            print(row)


if __name__ == "__main__":
    main()
