"""The forest benchmark: a fixed set of seeded forest worlds that spans difficulty, and its report.

``--world forest:<seed>`` (anywhere load_world takes a world name; plain ``forest`` is seed 0) is
``benchmark_forest(seed)`` (world_loader.generated_world): the seed draws the knobs (how much of the field to fill, the minimum
passage) as well as the layout, so consecutive seeds differ in difficulty, not only in layout.

    python -m simplebot_navigation.sim.forest --report [--seeds 0-199]

prints every world's knobs and C-space difficulty (narrowest passage, tortuosity) and the spread;
exit code 1 if a world was unsolvable.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from simplebot_navigation.sim.world import World
from simplebot_navigation.sim.world_gen import forest_world

FOREST_BENCHMARK_SEEDS = tuple(range(200))
BENCHMARK_ROBOT_RADIUS = 0.25
OCCUPANCY_RANGE = (0.008, 0.025)     # the top end is past what the passage rule lets fit: densest fields
MIN_PASSAGE_RANGE = (0.65, 0.9)
_KNOB_STREAM = 14                    # keeps the knob draws apart from the layout's generator


def benchmark_knobs(seed: int) -> dict:
    """Occupancy and minimum passage of benchmark world ``seed``, drawn from the seed."""
    rng = np.random.default_rng((_KNOB_STREAM, seed))
    return {"occupancy": round(float(rng.uniform(*OCCUPANCY_RANGE)), 4),
            "min_passage": round(float(rng.uniform(*MIN_PASSAGE_RANGE)), 3)}


def benchmark_forest(seed: int) -> World:
    """Benchmark world ``seed``: a 10 x 4.5 m field, checked solvable for the round body r = 0.25 m."""
    return forest_world(seed, robot_radius=BENCHMARK_ROBOT_RADIUS, **benchmark_knobs(seed))


def _seeds(text: str) -> list[int]:
    first, _, last = text.partition("-")
    return list(range(int(first), int(last or first) + 1))


def report(seeds) -> tuple[str, int]:
    """One row per world and a summary of the spread of the difficulty measures; and how many failed."""
    rows = ["  seed  occupancy  min_passage  cylinders  boxes  walls  narrowest  tortuosity  solvable"]
    narrowest, tortuosity, failures = [], [], []
    for seed in seeds:
        knobs = benchmark_knobs(seed)
        try:
            world = benchmark_forest(seed)
        except ValueError as err:
            failures.append(str(err))
            rows.append(f"{seed:6d}  {knobs['occupancy']:9.4f}  {knobs['min_passage']:11.3f}  "
                        f"{'-':>9}  {'-':>5}  {'-':>5}  {'-':>9}  {'-':>10}  no")
            continue
        cspace = world.extra["cspace"]
        narrowest.append(cspace["narrowest_passage"])
        tortuosity.append(cspace["tortuosity"])
        rows.append(f"{seed:6d}  {world.extra['occupancy']:9.4f}  {knobs['min_passage']:11.3f}  "
                    f"{len(world.cylinders):9d}  {len(world.boxes):5d}  {len(world.walls) - 4:5d}  "
                    f"{cspace['narrowest_passage']:9.3f}  {cspace['tortuosity']:10.4f}  yes")
    rows.append("")
    rows.append(f"{len(narrowest)} of {len(list(seeds))} worlds solvable for a disc of radius "
                f"{BENCHMARK_ROBOT_RADIUS} m plus the margin")
    for label, values in (("narrowest passage (m)", narrowest), ("tortuosity", tortuosity)):
        if values:
            q = np.percentile(values, [0, 10, 50, 90, 100])
            rows.append(f"{label:>22}: min {q[0]:.3f}  p10 {q[1]:.3f}  median {q[2]:.3f}  "
                        f"p90 {q[3]:.3f}  max {q[4]:.3f}")
    rows += failures
    return "\n".join(rows), len(failures)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m simplebot_navigation.sim.forest",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--report", action="store_true", help="print the difficulty of every benchmark world")
    parser.add_argument("--seeds", type=_seeds, default=list(FOREST_BENCHMARK_SEEDS),
                        help="seeds as 'first-last' or one seed (default: the benchmark set, 0-199)")
    args = parser.parse_args(argv)
    if not args.report:
        parser.print_help()
        return 2
    began = time.monotonic()
    text, failed = report(args.seeds)
    print(text)
    print(f"({time.monotonic() - began:.1f} s)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
