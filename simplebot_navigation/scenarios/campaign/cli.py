"""python -m simplebot_navigation.scenarios campaign [SPEC.yaml] [--worlds ...] --out R.jsonl [--jobs N | --ray ADDR]

Runs a campaign - every combination of worlds, robot bodies, parameter sets, goals and seeds, one
lockstep scenario per run - on worker processes here or on a Ray cluster, appending each finished
run to a JSON-lines file at once. --resume finishes a campaign that was stopped; at the end a table
per (world family x body x parameter set) is printed. Exit code 0 when every run produced a result,
1 when a run failed twice to produce one (crash or hang), 2 for bad input.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import os
import sys
import time
from collections import deque

import yaml

from simplebot_navigation.scenarios.campaign.execution import CampaignError, LocalExecutor, RayExecutor
from simplebot_navigation.scenarios.campaign.results import ResultsFile, latest_by_run, read_results
from simplebot_navigation.scenarios.campaign.spec import (CampaignSpec, Run, SpecError, params_label, plan,
                                                          spec_from_dict)
from simplebot_navigation.scenarios.campaign.stats import compare, comparison_table, summarize, summary_table

POLL_S = 1.0
MAX_JOBS = 256


class Progress:
    """Runs done / failed / running with an ETA: a tqdm bar when tqdm is installed, else one line per run."""

    def __init__(self, total: int, done: int, failed: int, stream=None):
        stream = stream or sys.stderr
        self.total, self.done, self.failed, self.stream = total, done, failed, stream
        self.already, self.started = done, time.monotonic()
        try:
            from tqdm import tqdm
        except ImportError:
            self.bar = None
        else:
            self.bar = tqdm(total=total, initial=done, unit="run", file=stream, dynamic_ncols=True)

    def eta(self) -> str:
        new = self.done - self.already
        if not new:
            return "?"
        seconds = (time.monotonic() - self.started) / new * (self.total - self.done)
        return f"{seconds // 3600:.0f}h{seconds % 3600 // 60:02.0f}m" if seconds >= 3600 else \
            f"{seconds // 60:.0f}m{seconds % 60:02.0f}s"

    def finished(self, record: dict, retrying: bool, running: int) -> None:
        if not retrying:
            self.done += 1
            self.failed += not record["success"]
        verdict = "ok" if record["success"] else "retry" if retrying else "FAIL"
        why = "" if record["success"] else f" ({'; '.join(record['failures'])})"
        took = "" if record["error"] else f" in {record['time_s']:.1f} s sim"
        line = (f"[{self.done}/{self.total}] {record['world']} seed {record['seed']} {record['robot']} "
                f"{params_label(record['params'])} goal {record['goal']}: {verdict} {record['status']}{took}{why}")
        if self.bar is not None:
            self.bar.write(line)
            self.bar.n = self.done
            self.bar.set_postfix_str(f"failed {self.failed}, running {running}")
        else:
            print(f"{line} | {self.done} done, {self.failed} failed, {running} running, ETA {self.eta()}",
                  file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_campaign(spec: CampaignSpec, out: str, executor, resume: bool = False, stream=None,
                 runs: list[Run] | None = None) -> list[dict]:
    """Every run not yet in ``out``, at most executor.slots at a time; returns the record that counts per run.

    ``runs`` is the spec's plan when the caller already has it (planning loads every world).
    """
    stream = stream or sys.stderr
    try:
        runs = plan(spec) if runs is None else runs
        results = ResultsFile(out, spec, resume)
    except BaseException:
        executor.close()
        raise
    pending = deque(run for run in runs if results.retry(run))
    if resume:
        print(f"resuming {out}: {len(runs) - len(pending)} of {len(runs)} runs already finished",
              file=stream, flush=True)
    latest = latest_by_run(read_results(out)[1])
    failed = sum(not record["success"] for key, record in latest.items() if key in results.finished)
    progress = Progress(len(runs), len(runs) - len(pending), failed, stream)
    running: dict[concurrent.futures.Future, Run] = {}
    try:
        while pending or running:
            while pending and len(running) < executor.slots:
                run = pending.popleft()
                running[executor.submit(run, spec.run_timeout)] = run
            done, _ = concurrent.futures.wait(running, timeout=POLL_S, return_when=concurrent.futures.FIRST_COMPLETED)
            for future in done:
                run = running.pop(future)
                try:
                    outcome = future.result()
                except Exception as err:  # the executor itself failed (a Ray worker died, say)
                    outcome = {"error": f"crashed: {type(err).__name__}: {err}", "log_tail": ""}
                record = results.record(run, outcome)
                retrying = results.retry(run)
                if retrying:
                    pending.appendleft(run)
                progress.finished(record, retrying, len(running))
    finally:
        progress.close()
        results.close()
        executor.close()
    return list(latest_by_run(read_results(out)[1]).values())


# -- command line ----------------------------------------------------------------------------------
def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m simplebot_navigation.scenarios campaign",
                                description=__doc__.split("\n\n")[1].replace("\n", " "))
    p.add_argument("spec", nargs="?", metavar="SPEC.yaml",
                   help="campaign spec (keys: worlds, seeds, robots, params, goals, run_timeout, time_budget); flags "
                        "override it")
    p.add_argument("--worlds", help="comma-separated built-in worlds, world files, or families 'forest:0-199'")
    p.add_argument("--seeds", help="seeds, e.g. 0-9 or 0,3,5 (default: 0)")
    p.add_argument("--robots", help="comma-separated bodies: box, round, round:R (radius R m; default: box)")
    p.add_argument("--set", action="append", metavar="'K=V [K=V ...]'",
                   help="a parameter set: K=V overrides and/or 'tight' (the shipped narrow-passage set) and/or "
                        "'no_collision_monitor' (move_base drives the base directly) and/or 'no_moving_obstacles' "
                        "(nothing tracked or predicted) and/or 'true_obstacles' (the simulator's moving obstacles instead "
                        "of the tracker's); "
                        "repeat for more sets, 'default' for none (default: none)")
    p.add_argument("--time-budget", type=float, metavar="S",
                   help="sim seconds per goal for every world (the BARN challenge's 100); default: from the shortest "
                        "path and max_vel_x. A spec file may give one per world family: {forest: 100}")
    p.add_argument("--goals", help="goal names 'a,b' and/or 'x,y,yaw;x,y,yaw' (default: every goal of each world)")
    p.add_argument("--run-timeout", type=float, help="wall seconds a run may take before it counts as hung "
                                                     "(default: 900)")
    p.add_argument("--out", metavar="results.jsonl", help="results file, one JSON line per finished run")
    executors = p.add_mutually_exclusive_group()
    executors.add_argument("--jobs", type=int, default=1, help="worker processes on this machine (default: 1)")
    executors.add_argument("--ray", metavar="local|auto|ADDRESS",
                           help="one Ray task per run: an embedded instance, this machine's cluster, or an address")
    p.add_argument("--resume", action="store_true", help="skip the runs --out already has, do the rest")
    p.add_argument("--plot", metavar="FIG.png", help="summary figure: success per group, times to goal")
    p.add_argument("--compare", nargs=2, metavar=("A.jsonl", "B.jsonl"),
                   help="compare two finished campaigns group by group, with significance; runs nothing")
    return p


def spec_from_args(parser: argparse.ArgumentParser, args: argparse.Namespace) -> CampaignSpec:
    """The spec file's keys, each replaced by its flag when given; errors name the key or flag."""
    flags = {"worlds": args.worlds, "seeds": args.seeds, "robots": args.robots, "goals": args.goals,
             "run_timeout": args.run_timeout, "params": args.set, "time_budget": args.time_budget}
    try:
        data = {}
        if args.spec:
            with open(args.spec, encoding="utf-8") as handle:
                data = yaml.safe_load(handle)
            if not isinstance(data, dict):
                raise SpecError(f"{args.spec}: expected a mapping of campaign keys, got {type(data).__name__}")
        data.update({key: value for key, value in flags.items() if value is not None})
        return spec_from_dict(data, source=args.spec or "the flags (--worlds)")
    except OSError as err:
        parser.error(f"{args.spec}: {err.strerror}")
    except yaml.YAMLError as err:
        parser.error(f"{args.spec}: not valid YAML: {err}")
    except SpecError as err:
        parser.error(str(err))


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.compare:
        try:
            sides = [list(latest_by_run(read_results(path)[1]).values()) for path in args.compare]
        except CampaignError as err:
            parser.error(f"--compare: {err}")
        print(comparison_table(compare(*sides)))
        return 0
    spec = spec_from_args(parser, args)
    if not args.out:
        parser.error("--out is required")
    if args.jobs < 1:
        parser.error(f"--jobs must be >= 1, got {args.jobs}")
    for option, path in (("--out", args.out), ("--plot", args.plot)):
        folder = os.path.dirname(os.path.abspath(path)) if path else None
        if folder and not os.path.isdir(folder):
            parser.error(f"{option} {path}: directory {folder} does not exist")
        if folder and not os.access(folder, os.W_OK | os.X_OK):
            parser.error(f"{option} {path}: directory {folder} is not writable")
    if args.jobs > MAX_JOBS:
        parser.error(f"--jobs must be at most {MAX_JOBS}, got {args.jobs}")
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    try:
        runs = plan(spec)
        executor = RayExecutor(args.ray) if args.ray else LocalExecutor(args.jobs)
        records = run_campaign(spec, args.out, executor, args.resume, runs=runs)
    except SpecError as err:
        parser.error(str(err))
    except CampaignError as err:
        print(f"campaign: error: {err}", file=sys.stderr)
        return 2
    print(summary_table(summarize(records)))
    print(f"results in {args.out}")
    if args.plot:
        from simplebot_navigation.scenarios.campaign.plot import hardest_runs, summary_figure

        summary_figure(args.plot, records)
        print(f"summary figure in {args.plot}; hardest runs in {', '.join(hardest_runs(args.plot, records))}")
    return 1 if any(r["error"] for r in records) else 0
