"""The summary figure of a campaign: success per group with its Wilson interval, and the times to goal."""

from __future__ import annotations

import numpy as np

from .campaign_stats import group_key, success_times, summarize


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
        right.boxplot([times[i] for i in shown], positions=rows[shown], vert=False, widths=0.6)
    right.set_yticks(rows, [""] * len(rows))
    right.set_ylim(left.get_ylim())
    right.set_xlabel("time to goal of successful runs [s sim]")
    fig.suptitle(f"campaign: {len(records)} runs, {sum(r['success'] for r in records)} succeeded")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
