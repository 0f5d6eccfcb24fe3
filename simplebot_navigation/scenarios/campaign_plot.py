"""The figures of a campaign: success per group with its Wilson interval, times to goal, and the hardest runs
drawn over their worlds (failures first, then the slowest relative to their path)."""

from __future__ import annotations

import dataclasses
import math
import os
import tempfile

import numpy as np

from simplebot_description import robot_description
from simplebot_navigation.sim.world_loader import load_world

from .campaign_spec import params_label
from .campaign_stats import group_key, success_times, summarize
from .report import plot
from .runner import GoalResult, world_for_run

HARDEST = 4


def summary_figure(path: str, records: list[dict]) -> None:
    """Left: success rate per (family, body, parameter set); right: the successful runs' times to goal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summaries = summarize(records)
    labels = [f"{s.family}\n{s.robot}, {s.params[:24]}" for s in summaries]
    rates = np.array([s.rate for s in summaries])
    low = np.array([s.interval[0] for s in summaries])
    high = np.array([s.interval[1] for s in summaries])
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 1.0 + 0.6 * max(3, len(summaries))))
    rows = np.arange(len(summaries))
    left.barh(rows, 100 * rates, color="tab:green", alpha=0.7)
    left.errorbar(100 * rates, rows, xerr=[100 * (rates - low), 100 * (high - rates)], fmt="none", ecolor="black",
                  capsize=3)
    for row, s in zip(rows, summaries):
        left.annotate(f"{s.successes}/{s.runs}", (2, row), va="center", fontsize=8)
    left.set_yticks(rows, labels, fontsize=8)
    left.set_xlim(0, 100)
    left.set_xlabel("success % (Wilson 95 % interval)")
    left.invert_yaxis()
    times = [success_times([r for r in records if group_key(r) == (s.family, s.robot, s.params)])
             for s in summaries]
    shown = [i for i, t in enumerate(times) if t]
    if shown:
        right.boxplot([times[i] for i in shown], positions=rows[shown], orientation="horizontal", widths=0.6)
    right.set_yticks(rows, [""] * len(rows))
    right.set_ylim(left.get_ylim())
    right.set_xlabel("time to goal of successful runs [s sim]")
    fig.suptitle(f"campaign: {len(records)} runs, {sum(r['success'] for r in records)} succeeded")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def hardness(record: dict) -> tuple[bool, float]:
    """Sort key, hardest first: failed runs, then time per (path length / max speed)."""
    ratio = record["time_s"] / (record["path_length"] / record["max_vel_x"]) if record.get("path_length") else math.inf
    return record["success"], -ratio


def hardest_runs(path: str, records: list[dict], count: int = HARDEST) -> list[str]:
    """The ``count`` hardest runs that have a trajectory, one PNG each next to ``path``; returns the files."""
    drawn = [r for r in records if r.get("trajectory")]
    fields = {f.name for f in dataclasses.fields(GoalResult)}
    stem = os.path.splitext(path)[0]
    files = []
    for rank, record in enumerate(sorted(drawn, key=hardness)[:count], 1):
        result = GoalResult(**{k: v for k, v in record.items() if k in fields} | {"run": 0, "goal": record["goal"]})
        if result.min_clearance is None:
            result = dataclasses.replace(result, min_clearance=math.inf)
        with tempfile.TemporaryDirectory(prefix="simplebot_campaign_plot_") as folder:
            world = load_world(world_for_run(record["world"], record["seed"], folder),
                               robot_radius=robot_description(record["robot"]).inscribed_radius)
        verdict = "ok" if record["success"] else record["status"]
        files.append(f"{stem}_hardest_{rank}.png")
        plot(files[-1], world, [result], f"{record['world']} seed {record['seed']}, {record['robot']}, "
                                         f"{params_label(record['params'])}: {verdict}")
    return files
