"""Global planner plan time against pyastar2d (C++ A*) and a plain heapq Dijkstra, side by side.

    python bench/global_planner.py [--quick]

Maps (obstacles inflated with the project's InflationLayer):
  lab    150 x 150 at 0.2 m (the lab's 30 x 30 m global costmap): walls with doors, boxes;
         inflation_radius 1.5, cost_scaling_factor 8, inscribed radius 0.33 (lab footprint).
  1000   1000 x 1000 at 0.05 m, seeded random boxes; ROS default inflation (0.55 m, 10).
  2000   2000 x 2000 at 0.05 m, same generator.
Start and goal are free cells near opposite corners. Every planner runs on the same weighted
grid: the global_planner cell cost (c * 3 + 50, capped at 252; 252..254 blocked) divided by
the neutral cost, so free space weighs 1 as pyastar2d requires. Path cost is the line
integral of that weight along each path (in cells, sampled every 0.1 cell), so the columns
compare paths of the same metric; "ours A*" minimises its own step cost (c + 50) instead.
"x pyastar" is the median time over pyastar2d's on the same 4-neighbour grid graph.
The first-call line times a fresh process planning once: numba compiling into an empty cache,
then loading the cache that run left behind.
"""

from __future__ import annotations

import argparse
import heapq
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import pyastar2d  # noqa: E402

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE  # noqa: E402
from simplebot_navigation.costmap.costmap_2d import Costmap2D  # noqa: E402
from simplebot_navigation.costmap.inflation_layer import InflationLayer  # noqa: E402
from simplebot_navigation.planning import make_global_planner, warm_up  # noqa: E402
from simplebot_navigation.planning.global_planner import global_planner_costs  # noqa: E402

NEUTRAL = 50.0


def inflate(costmap: Costmap2D, inscribed: float, radius: float, weight: float) -> None:
    layer = InflationLayer("inflation_layer", inflation_radius=radius, cost_scaling_factor=weight)
    layer.layered_costmap = SimpleNamespace(costmap=costmap, inscribed_radius=inscribed)
    layer.on_initialize()
    layer.on_footprint_changed()
    layer.update_costs(costmap, 0, 0, costmap.size_x, costmap.size_y)


def lab_map() -> Costmap2D:
    cm = Costmap2D(150, 150, 0.2, -15.0, -15.0)
    g = cm.costmap

    def wall(x0, y0, x1, y1):
        (a, b), (c, d) = cm.world_to_map(x0, y0), cm.world_to_map(x1, y1)
        g[b:d + 1, a:c + 1] = LETHAL_OBSTACLE

    wall(-15, -15, 14.9, -14.8)
    wall(-15, 14.7, 14.9, 14.9)
    wall(-15, -15, -14.8, 14.9)
    wall(14.7, -15, 14.9, 14.9)
    # Two interior walls along y, one along x, each with 1.4 m doors.
    wall(-5, -14, -4.8, -6)
    wall(-5, -4.6, -4.8, 6)
    wall(-5, 7.4, -4.8, 14)
    wall(5, -14, 5.2, 2)
    wall(5, 3.4, 5.2, 14)
    wall(-14, 0, -9, 0.2)
    wall(-7.6, 0, -5, 0.2)
    for x, y in ((-10, -8), (0, -9), (0, 5), (9, -6), (10, 8), (-10, 9)):
        wall(x - 0.6, y - 0.6, x + 0.6, y + 0.6)
    inflate(cm, 0.33, 1.5, 8.0)
    return cm


def cluttered_map(n: int, seed: int) -> Costmap2D:
    cm = Costmap2D(n, n, 0.05, 0.0, 0.0)
    rng = np.random.default_rng(seed)
    g = cm.costmap
    for _ in range(n * n // 4000):
        w, h = rng.integers(4, 40, size=2)
        x, y = rng.integers(0, n - 40, size=2)
        g[y:y + h, x:x + w] = LETHAL_OBSTACLE
    inflate(cm, 0.33, 0.55, 10.0)
    return cm


def free_cell_near(cm: Costmap2D, fx: float, fy: float) -> tuple[int, int]:
    ys, xs = np.nonzero(cm.costmap == 0)
    tx, ty = fx * cm.size_x, fy * cm.size_y
    i = np.argmin((xs - tx) ** 2 + (ys - ty) ** 2)
    return int(xs[i]), int(ys[i])


def heapq_dijkstra(weights: np.ndarray, start: tuple[int, int], goal: tuple[int, int]):
    """4-connected Dijkstra, entering a cell costs its weight; returns (row, col) cells."""
    h, w = weights.shape
    flat = weights.ravel().tolist()
    dist = [float("inf")] * (h * w)
    prev = [-1] * (h * w)
    s, t = start[0] * w + start[1], goal[0] * w + goal[1]
    dist[s] = 0.0
    queue = [(0.0, s)]
    while queue:
        d, i = heapq.heappop(queue)
        if i == t:
            break
        if d > dist[i]:
            continue
        r, c = divmod(i, w)
        for j, ok in ((i - 1, c > 0), (i + 1, c < w - 1), (i - w, r > 0), (i + w, r < h - 1)):
            if ok:
                nd = d + flat[j]
                if nd < dist[j]:
                    dist[j] = nd
                    prev[j] = i
                    heapq.heappush(queue, (nd, j))
    if dist[t] == float("inf"):
        return None
    cells = [t]
    while cells[-1] != s:
        cells.append(prev[cells[-1]])
    return np.array([divmod(i, w) for i in reversed(cells)])


def path_quality(weights: np.ndarray, xy_cells: np.ndarray, resolution: float):
    """(cost, length in m) of a polyline given in cell coordinates (x, y; integer = centre)."""
    seg = np.diff(xy_cells, axis=0)
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    n = np.maximum(np.ceil(seg_len / 0.1).astype(int), 1)
    cost = 0.0
    for p, d, k, ln in zip(xy_cells[:-1], seg, n, seg_len):
        t = (np.arange(k) + 0.5) / k
        pts = p + t[:, None] * d
        cx = np.clip(np.floor(pts[:, 0] + 0.5).astype(int), 0, weights.shape[1] - 1)
        cy = np.clip(np.floor(pts[:, 1] + 0.5).astype(int), 0, weights.shape[0] - 1)
        cost += float(weights[cy, cx].sum()) * ln / k
    return cost, float(seg_len.sum()) * resolution


def timed(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return np.array(times) * 1e3, out


def first_call_seconds() -> tuple[float, float]:
    code = ("import time; t = time.perf_counter(); "
            "from simplebot_navigation.planning import warm_up; warm_up(); "
            "print(time.perf_counter() - t)")
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        runs = [float(subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                     capture_output=True, text=True).stdout) for _ in range(2)]
    return runs[0], runs[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, no 2000 x 2000")
    args = parser.parse_args()

    cold, cached = first_call_seconds()
    warm_up()
    lut = global_planner_costs(253, 50, 3.0, allow_unknown=True) / NEUTRAL
    cases = [("lab 150x150", lab_map(), 101 if not args.quick else 21, 21),
             ("1000x1000", cluttered_map(1000, 1), 9 if not args.quick else 3, 1)]
    if not args.quick:
        cases.append(("2000x2000", cluttered_map(2000, 2), 5, 1))

    print(f"first plan in a fresh process: {cold:.2f} s compiling (empty numba cache), "
          f"{cached:.2f} s with the cache")
    header = f"{'map':<12} {'planner':<22} {'runs':>4} {'median ms':>10} {'p95 ms':>9} " \
             f"{'x pyastar':>9} {'cost':>10} {'length m':>9}"
    print(header)
    print("-" * len(header))
    for name, cm, repeats, base_repeats in cases:
        s = free_cell_near(cm, 0.04, 0.04)
        g = free_cell_near(cm, 0.96, 0.96)
        start = (*cm.map_to_world(*s), 0.0)
        goal = (*cm.map_to_world(*g), 0.0)
        rows, ours = [], []
        for label, params in (("ours Dijkstra", {}), ("ours A*", {"use_dijkstra": False})):
            planner = make_global_planner("global_planner/GlobalPlanner", params)
            # make_plan outlines the map and frees the start cell: the same writes every call.
            ms, res = timed(lambda: planner.make_plan(cm, start, goal), repeats)
            if not res.ok:
                raise SystemExit(f"{name}: {label} failed: {res.message}")
            ours.append((label, ms, res))
        # The other planners search the same (outlined) grid.
        weights = lut[cm.costmap]
        for label, ms, res in ours:
            lattice = (res.poses[:, :2] - [cm.origin_x, cm.origin_y]) / cm.resolution - 0.5
            rows.append((label, ms, path_quality(weights, lattice, cm.resolution)))
        for label, diag in (("pyastar2d 4-conn", False), ("pyastar2d 8-conn", True)):
            ms, cells = timed(lambda: pyastar2d.astar_path(weights, s[::-1], g[::-1],
                                                           allow_diagonal=diag), repeats)
            rows.append((label, ms, path_quality(weights, cells[:, ::-1].astype(float),
                                                 cm.resolution)))
            if not diag:
                ref = np.median(ms)
        ms, cells = timed(lambda: heapq_dijkstra(weights, s[::-1], g[::-1]), base_repeats)
        rows.append(("heapq Dijkstra", ms, path_quality(weights, cells[:, ::-1].astype(float),
                                                        cm.resolution)))
        for label, ms, (cost, length) in rows:
            print(f"{name:<12} {label:<22} {len(ms):>4} {np.median(ms):>10.2f} "
                  f"{np.percentile(ms, 95):>9.2f} {np.median(ms) / ref:>9.2f} {cost:>10.1f} "
                  f"{length:>9.2f}")
        print()


if __name__ == "__main__":
    main()
