"""amcl's sensor update and resampling time (docs/reference.md §8).

    python bench/amcl.py [--repeats N] [--particles N]

The lab's occupancy grid at 5 cm (505 x 385 cells) and the robot's two lidars (683 beams each, 0.02 m noise)
seen from a pose in the corridor. Each row weighs N particles (default 2000, spread around the true pose with
sigma 0.3 m, 0.3 m, 0.2 rad, a filter still converging) against both scans: Amcl.sensor_update as the node calls
it, with resample_interval high enough that it does not resample, so the row is the laser model alone. The
resample row times ParticleFilter.resample on the same particles with max_particles = N (KLD sampling then keeps
the number the row shows). The kernels run on one thread (localization/amcl_kernels.py says why). The first-call
time is a fresh process's first update with each model: loading the compiled kernels from numba's cache (or
compiling them when the cache is empty).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simplebot_navigation.localization import Amcl, AmclParams  # noqa: E402
from simplebot_navigation.localization.laser_models import read_beams  # noqa: E402
from simplebot_navigation.testing.amcl_scenes import lab_map, lab_scanner  # noqa: E402

POSE = (-6.0, 0.2, 0.3)
SPREAD = (0.3, 0.3, 0.2)
FIRST_CALL = """
import time, numpy as np
start = time.perf_counter()
from simplebot_navigation.localization import Amcl, AmclParams
from simplebot_navigation.testing.amcl_scenes import lab_map, lab_scanner
grid, resolution, origin = lab_map()
scans = lab_scanner().scans((0.0, 0.0, 0.0), np.random.default_rng(0))
ready = time.perf_counter()
for model in ("likelihood_field", "likelihood_field_prob", "beam"):
    amcl = Amcl(AmclParams(laser_model_type=model, resample_interval=1), grid, resolution, origin)
    amcl.odometry_update((0.0, 0.0, 0.0))
    amcl.sensor_update(scans)
print(f"{time.perf_counter() - ready:.2f}")
"""


def spread_particles(amcl: Amcl, n: int, rng: np.random.Generator) -> None:
    poses = np.asarray(POSE) + rng.normal(0.0, 1.0, (n, 3)) * np.asarray(SPREAD)
    amcl.filter.poses = poses
    amcl.filter.weights = np.full(n, 1.0 / n)


def time_update(model: str, beams: int, n: int, repeats: int) -> tuple[np.ndarray, int]:
    """Seconds of each of ``repeats`` sensor updates with both scans, and the beams used per scan."""
    grid, resolution, origin = lab_map()
    params = AmclParams(laser_model_type=model, laser_max_beams=beams, max_particles=n, resample_interval=1000)
    amcl = Amcl(params, grid, resolution, origin)
    rng = np.random.default_rng(1)
    scans = lab_scanner().scans(POSE, rng)
    times = []
    for k in range(repeats + 3):
        spread_particles(amcl, n, rng)
        amcl.request_nomotion_update()
        amcl.odometry_update((0.0, 0.0, 0.0))
        started = time.perf_counter()
        amcl.sensor_update(scans)
        if k >= 3:
            times.append(time.perf_counter() - started)
    return np.array(times), len(read_beams(scans[0], params)[0])


def time_resample(n: int, repeats: int) -> tuple[np.ndarray, int]:
    grid, resolution, origin = lab_map()
    amcl = Amcl(AmclParams(max_particles=n), grid, resolution, origin)
    rng = np.random.default_rng(2)
    times, counts = [], []
    for k in range(repeats + 3):
        spread_particles(amcl, n, rng)
        amcl.filter.weights = rng.random(n)
        amcl.filter.weights /= amcl.filter.weights.sum()
        started = time.perf_counter()
        amcl.filter.resample()
        if k >= 3:
            times.append(time.perf_counter() - started)
            counts.append(len(amcl.filter.poses))
    return np.array(times), int(np.median(counts))


def load_average() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def first_call() -> str:
    out = subprocess.run([sys.executable, "-c", FIRST_CALL], cwd=ROOT, capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    return out.stdout.strip().splitlines()[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=100)
    parser.add_argument("--particles", type=int, default=2000)
    args = parser.parse_args()
    print(f"particles {args.particles}, first call (3 models) {first_call()} s, load average {load_average()}")
    print(f"{'what':<32} {'max_beams':>9} {'used/scan':>9} {'p50 ms':>8} {'p95 ms':>8} {'max ms':>8}")
    rows = [(m, b) for m in ("likelihood_field", "likelihood_field_prob", "beam") for b in (30, 683)]
    for model, beams in rows:
        times, used = time_update(model, beams, args.particles, args.repeats)
        report(f"{model}, 2 scans", str(beams), str(used), times)
    times, kept = time_resample(args.particles, args.repeats)
    report(f"resample (KLD keeps {kept})", "", "", times)


def report(what: str, max_beams: str, used: str, times: np.ndarray) -> None:
    ms = times * 1e3
    print(f"{what:<32} {max_beams:>9} {used:>9} {np.median(ms):>8.2f} {np.percentile(ms, 95):>8.2f} "
          f"{ms.max():>8.2f}")


if __name__ == "__main__":
    main()
