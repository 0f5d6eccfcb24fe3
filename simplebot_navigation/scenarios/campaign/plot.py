"""The figures of a campaign: success per group with its Wilson interval, times to goal, success by the
difficulty of generated worlds (their narrowest C-space passage), and the hardest runs drawn over their
worlds (failures first, then the slowest relative to their path)."""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import tempfile

import numpy as np

from simplebot_description import robot_description
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.scenarios.campaign.spec import params_label, robot_body
from simplebot_navigation.scenarios.campaign.stats import group_key, success_times, summarize, wilson_interval
from simplebot_navigation.scenarios.report import plot
from simplebot_navigation.scenarios.runner import GoalResult, world_for_run

HARDEST = 4
DIFFICULTY_BINS = 4


def _world(record: dict):
    with tempfile.TemporaryDirectory(prefix="simplebot_campaign_plot_") as folder:
        return load_world(world_for_run(record["world"], record["seed"], folder),
                          robot_radius=robot_description(*robot_body(record["robot"])).inscribed_radius)


@functools.lru_cache(maxsize=None)
def _narrowest_passage(world: str) -> float | None:
    """The narrowest passage of a generated world's C-space path (forest:<seed>), None for other worlds."""
    if ":" not in world or "/" in world:
        return None
    return load_world(world).extra.get("cspace", {}).get("narrowest_passage")


def success_by_difficulty(records: list[dict], bins: int = DIFFICULTY_BINS) -> list[tuple]:
    """(narrowest passage from, to, successes, runs, Wilson interval) per quantile bin of the generated worlds."""
    rated = [(p, r["success"]) for r in records if (p := _narrowest_passage(r["world"])) is not None]
    if not rated:
        return []
    passages = np.array([p for p, _ in rated])
    edges = np.unique(np.quantile(passages, np.linspace(0, 1, bins + 1)))
    rows = []
    for i, (low, high) in enumerate(zip(edges[:-1], edges[1:])):
        inside = [ok for p, ok in rated if low <= p < high or (i == len(edges) - 2 and p == high)]
        if inside:
            rows.append((float(low), float(high), sum(inside), len(inside), wilson_interval(sum(inside), len(inside))))
    return rows


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
    by_difficulty = success_by_difficulty(records)
    fig, axes = plt.subplots(1, 3 if by_difficulty else 2, figsize=(18 if by_difficulty else 12,
                                                                     1.0 + 0.6 * max(4, len(summaries))))
    left, right = axes[:2]
    rows = np.arange(len(summaries))
    left.barh(rows, 100 * rates, color="tab:green", alpha=0.7)
    left.errorbar(100 * rates, rows, xerr=100 * np.clip([rates - low, high - rates], 0, None), fmt="none", ecolor="black",
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
    if by_difficulty:
        ax = axes[2]
        centres = [(a + b) / 2 for a, b, *_ in by_difficulty]
        rates = np.array([ok / n for _, _, ok, n, _ in by_difficulty])
        errors = np.clip([[rate - ci[0], ci[1] - rate] for rate, (*_, ci) in zip(rates, by_difficulty)], 0, None).T
        ax.errorbar(centres, 100 * rates, yerr=100 * errors, fmt="o-", capsize=3)
        for (a, b, ok, n, _), x, rate in zip(by_difficulty, centres, rates):
            ax.annotate(f"{ok}/{n}\n{a:.2f}-{b:.2f} m", (x, 100 * rate), textcoords="offset points", xytext=(0, -28),
                        ha="center", fontsize=7)
        ax.set_ylim(-10, 105)
        ax.set_xlabel("narrowest C-space passage of the world [m] (quartiles)")
        ax.set_ylabel("success %")
        ax.set_title("generated worlds by difficulty", fontsize=9)
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
        world = _world(record)
        verdict = "ok" if record["success"] else record["status"]
        files.append(f"{stem}_hardest_{rank}.png")
        plot(files[-1], world, [result], f"{record['world']} seed {record['seed']}, {record['robot']}, "
                                         f"{params_label(record['params'])}: {verdict}")
    return files
