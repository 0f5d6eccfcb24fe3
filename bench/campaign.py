"""Wall time of one short campaign run sequentially, on --jobs N worker processes, and on a local Ray.

    python bench/campaign.py                      (20 runs: the empty world, 2 goals x 10 seeds; 1 vs 2 jobs)
    python bench/campaign.py --runs 8 --ray          (and on an embedded Ray instance)

Every executor runs the same campaign; the per-run outcomes must be identical (lockstep), so the
comparison is of wall time only. The load of the machine shows in the numbers: note it with them. The
CPU ceiling line is the speed-up plain Python processes get on the same CPUs at the same time; an
executor's speed-up is judged against it.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from simplebot_navigation.scenarios.campaign.cli import run_campaign  # noqa: E402
from simplebot_navigation.scenarios.campaign.execution import LocalExecutor, RayExecutor  # noqa: E402
from simplebot_navigation.scenarios.campaign.spec import spec_from_dict  # noqa: E402

GOALS = ["1,0,0", "0.8,0.4,0.5"]
OUTCOME = ("success", "status", "time_s", "path_length", "collisions", "final")
SPIN = "s = 0\nfor i in range(25_000_000): s += i"


def cpu_ceiling(jobs: int) -> float:
    """The speed-up ``jobs`` processes of pure Python get on this machine: the most any executor can get.

    On a virtual machine whose CPUs are hyperthreads, or share a host that is busy, it is well below ``jobs``.
    """
    def wall(n: int) -> float:
        started = time.monotonic()
        for process in [subprocess.Popen([sys.executable, "-c", SPIN]) for _ in range(n)]:
            process.wait()
        return time.monotonic() - started
    alone = min(wall(1) for _ in range(2))
    together = min(wall(jobs) for _ in range(2))
    return jobs * alone / together


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=20, help="runs, an even number (2 goals x runs/2 seeds)")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--ray", action="store_true", help="also on an embedded Ray instance (one task per CPU)")
    args = p.parse_args()
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    spec = spec_from_dict({"worlds": "empty", "goals": GOALS, "seeds": f"0-{args.runs // 2 - 1}"})
    executors = [("sequential", lambda: LocalExecutor(1)), (f"--jobs {args.jobs}", lambda: LocalExecutor(args.jobs))]
    if args.ray:
        executors.append(("--ray local (all CPUs)", lambda: RayExecutor("local")))
    walls, outcomes = {}, {}
    print(f"{len(GOALS) * len(spec.seeds)} runs, load average {os.getloadavg()[0]:.1f} at the start", flush=True)
    print(f"CPU ceiling: {args.jobs} processes of pure Python run {cpu_ceiling(args.jobs):.2f}x as fast as one",
          flush=True)
    with tempfile.TemporaryDirectory(prefix="simplebot_bench_campaign_") as folder:
        for name, make in executors:
            started = time.monotonic()
            records = run_campaign(spec, os.path.join(folder, f"{len(walls)}.jsonl"), make())
            walls[name] = time.monotonic() - started
            outcomes[name] = {(r["seed"], r["goal"]): tuple(str(r[k]) for k in OUTCOME) for r in records}
            print(f"{name:<28} {walls[name]:7.1f} s wall, {sum(r['success'] for r in records)}/{len(records)} "
                  f"succeeded, speed-up {walls['sequential'] / walls[name]:.2f}x", flush=True)
    same = all(o == outcomes["sequential"] for o in outcomes.values())
    print(f"per-run outcomes identical across executors: {same}; load average {os.getloadavg()[0]:.1f} at the end")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
