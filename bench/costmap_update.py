"""Costmap update time for the lab's costmaps, package vs a per-cell pure-Python reference, same run.

    python bench/costmap_update.py [--steps N]

Each step the robot creeps forward (3 cm, a little turn), both 683-beam lab scans arrive, and
update_map runs (local: 5 x 5 m at 0.05, rolling; global: 30 x 30 m at 0.2). The reference
(simplebot_navigation/testing/costmap_reference.py) is fed the same observations; the grids are compared cell for cell.
Times are per update_map; scan projection is timed separately (it runs in the scan callbacks).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.costmap.costmap_core import CostmapCore  # noqa: E402
from simplebot_navigation.testing import costmap_scene as scenario  # noqa: E402
from simplebot_navigation.testing.costmap_reference import ReferenceCostmap  # noqa: E402
from simplebot_navigation.testing.lab_params import global_costmap_params, local_costmap_params  # noqa: E402

WARMUP = 2


def stats(samples):
    ms = np.array(samples) * 1e3
    return float(np.median(ms)), float(np.percentile(ms, 95))


def run(name: str, params: dict, steps: int):
    clock = [0.0]
    cm = CostmapCore(name, params, clock=lambda: clock[0])
    c = cm.config
    ref = ReferenceCostmap(c.size_x, c.size_y, c.resolution, c.origin_x, c.origin_y, c.rolling_window, True,
                           [tuple(p) for p in cm.footprint], 1.5, 8.0)
    layer = cm.layer("obstacles")
    t_pkg, t_ref, t_scan, identical = [], [], [], True
    for k, (x, y, yaw) in enumerate(scenario.robot_path(steps + WARMUP)):
        clock[0] = 0.1 * k
        observations = []
        start = time.perf_counter()
        for laser in scenario.LASERS:
            pose = scenario.laser_pose(x, y, yaw, laser)
            ranges = scenario.scan_ranges(pose[0], pose[1], pose[3])
            cm.add_laser_scan(laser, ranges, scenario.ANGLE_MIN, scenario.ANGLE_INCREMENT, scenario.RANGE_MIN,
                              scenario.RANGE_MAX, pose, clock[0])
            observations.append(layer.buffers[laser].get_observations()[0])
        scan_time = time.perf_counter() - start
        start = time.perf_counter()
        cm.update_map(x, y, yaw)
        pkg_time = time.perf_counter() - start
        start = time.perf_counter()
        ref.update(x, y, yaw, observations)
        ref_time = time.perf_counter() - start
        identical &= bool(np.array_equal(cm.costmap.costmap, np.array(ref.master, np.uint8)))
        if k >= WARMUP:
            t_pkg.append(pkg_time)
            t_ref.append(ref_time)
            t_scan.append(scan_time)
    return stats(t_pkg), stats(t_ref), stats(t_scan), identical


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=30, help="timed updates per costmap (default 30)")
    args = parser.parse_args()
    rows = []
    for name, params, target in (("local 5x5 m @0.05 rolling", local_costmap_params(), 5.0),
                                 ("global 30x30 m @0.2", global_costmap_params(), 10.0)):
        rows.append((name, target) + run(name, params, args.steps))
    print(f"costmap update_map, {args.steps} steps after {WARMUP} warm-up, 2 x {scenario.BEAMS}-beam scans per step")
    header = (f"{'costmap':<27} {'median ms':>9} {'p95 ms':>8} {'target':>7} | {'reference median':>16} "
              f"{'p95':>8} | {'ratio':>6} | {'scan->obs ms':>12} | identical")
    print(header)
    print("-" * len(header))
    for name, target, (med, p95), (rmed, rp95), (smed, _), identical in rows:
        print(f"{name:<27} {med:>9.2f} {p95:>8.2f} {'<=' + format(target, 'g'):>7} | {rmed:>16.1f} {rp95:>8.1f} | "
              f"{rmed / med:>5.0f}x | {smed:>12.2f} | {'yes' if identical else 'NO'}")


if __name__ == "__main__":
    main()
