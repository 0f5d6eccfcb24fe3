"""Campaign statistics: per-group success with a Wilson interval, times, failure reasons; two campaigns compared.

A group is (world family x robot body x parameter set). Success rates of two campaigns are compared
with Fisher's exact test on the 2x2 table (small groups are the rule), mean times to goal with
Welch's t-test; both two-sided, significant below ALPHA.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy import stats

from simplebot_navigation.scenarios.campaign.spec import params_label

Z95 = 1.959963984540054
ALPHA = 0.05


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Score interval of a binomial proportion; unlike the normal one it stays inside [0, 1] at 0/n and n/n."""
    if n == 0:
        return math.nan, math.nan
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def group_key(record: dict) -> tuple[str, str, str]:
    return record["family"], record["robot"], params_label(record["params"])


def failure_kind(text: str) -> str:
    """A failure without its numbers, so that equal reasons count together ('3 collision(s)' -> 'collision')."""
    if "collision" in text:
        return "collision"
    if "from the goal" in text:
        return "off the goal"
    if text.startswith("yaw off"):
        return "yaw off"
    return re.split(r"[:(]", text, maxsplit=1)[0].strip() or text


@dataclass
class GroupSummary:
    family: str
    robot: str
    params: str
    runs: int
    successes: int
    errors: int
    collisions: int          # while the robot moved
    struck_standing: int     # moving obstacles that ran into the standing robot
    mean_time_s: float       # of the successful runs
    p95_time_s: float
    time_ratio: float        # mean of time / (path length / max speed) over successful runs
    failures: Counter
    challenge_score: float = math.nan   # the BARN challenge's mean score over every run (runner.challenge_score)

    @property
    def rate(self) -> float:
        return self.successes / self.runs if self.runs else math.nan

    @property
    def interval(self) -> tuple[float, float]:
        return wilson_interval(self.successes, self.runs)


def success_times(records: list[dict]) -> list[float]:
    return [r["time_s"] for r in records if r["success"]]


def summarize(records: list[dict]) -> list[GroupSummary]:
    """One summary per group, in the order the groups first appear."""
    groups: dict[tuple, list[dict]] = {}
    for record in records:
        groups.setdefault(group_key(record), []).append(record)
    summaries = []
    for (family, robot, params), members in groups.items():
        times = success_times(members)
        ratios = [r["time_s"] / (r["path_length"] / r["max_vel_x"]) for r in members
                  if r["success"] and r.get("path_length") and r.get("max_vel_x")]
        summaries.append(GroupSummary(
            family, robot, params, len(members), sum(r["success"] for r in members),
            sum(bool(r["error"]) for r in members), sum(r.get("collisions") or 0 for r in members),
            sum(r.get("struck_standing") or 0 for r in members),
            float(np.mean(times)) if times else math.nan, float(np.percentile(times, 95)) if times else math.nan,
            float(np.mean(ratios)) if ratios else math.nan,
            Counter(failure_kind(f) for r in members for f in r.get("failures") or []),
            float(np.mean([r.get("challenge_score") or 0.0 for r in members]))))
    return summaries


def summary_table(summaries: list[GroupSummary]) -> str:
    header = (f"{'family':<12} {'robot':<10} {'params':<34} {'runs':>5} {'success':>8} {'Wilson 95 %':>13} "
              f"{'coll':>5} {'struck':>6} {'mean s':>7} {'p95 s':>7} {'t/(L/v)':>7} {'score':>6}  failures")
    lines = [header, "-" * len(header)]
    for s in summaries:
        low, high = s.interval
        reasons = ", ".join(f"{kind} x{n}" for kind, n in s.failures.most_common()) or "-"
        lines.append(f"{s.family[:12]:<12} {s.robot[:10]:<10} {s.params[:34]:<34} {s.runs:>5} {100 * s.rate:>7.0f}% "
                     f"{100 * low:>5.0f}-{100 * high:>3.0f} % {s.collisions:>5} {s.struck_standing:>6} {s.mean_time_s:>7.1f} "
                     f"{s.p95_time_s:>7.1f} {s.time_ratio:>7.2f} {s.challenge_score:>6.3f}  {reasons}")
    return "\n".join(lines)


# -- two campaigns ---------------------------------------------------------------------------------
@dataclass
class Comparison:
    group: tuple[str, str, str]
    a: tuple[int, int]              # successes, runs
    b: tuple[int, int]
    rate_p: float                   # Fisher's exact test, two-sided
    mean_a: float
    mean_b: float
    time_p: float                   # Welch's t-test on the successful runs' times, two-sided

    @property
    def rate_difference(self) -> float:
        return self.b[0] / self.b[1] - self.a[0] / self.a[1]


def fisher_p(a: tuple[int, int], b: tuple[int, int]) -> float:
    table = [[a[0], a[1] - a[0]], [b[0], b[1] - b[0]]]
    return float(stats.fisher_exact(table, alternative="two-sided").pvalue)


def welch_p(times_a: list[float], times_b: list[float]) -> float:
    """nan with fewer than two times on a side, or no spread at all (the test is undefined)."""
    if len(times_a) < 2 or len(times_b) < 2 or (np.var(times_a) == 0 and np.var(times_b) == 0):
        return math.nan
    return float(stats.ttest_ind(times_a, times_b, equal_var=False).pvalue)


def compare(records_a: list[dict], records_b: list[dict]) -> list[Comparison]:
    """Groups are matched by (family, robot, params); when each side has a single parameter set the sets
    are matched to each other, so campaign B with tuned parameters compares against campaign A's defaults."""
    labels_a = {params_label(r["params"]) for r in records_a}
    labels_b = {params_label(r["params"]) for r in records_b}
    single = len(labels_a) == 1 and len(labels_b) == 1

    def key(record: dict) -> tuple[str, str, str]:
        family, robot, params = group_key(record)
        return family, robot, "*" if single else params

    groups_a, groups_b = {}, {}
    for records, groups in ((records_a, groups_a), (records_b, groups_b)):
        for record in records:
            groups.setdefault(key(record), []).append(record)
    comparisons = []
    for group in [g for g in groups_a if g in groups_b]:
        a, b = groups_a[group], groups_b[group]
        counts_a, counts_b = (sum(r["success"] for r in a), len(a)), (sum(r["success"] for r in b), len(b))
        times_a, times_b = success_times(a), success_times(b)
        label = (*group[:2], f"{min(labels_a)} -> {min(labels_b)}") if single else group
        comparisons.append(Comparison(
            label, counts_a, counts_b, fisher_p(counts_a, counts_b),
            float(np.mean(times_a)) if times_a else math.nan, float(np.mean(times_b)) if times_b else math.nan,
            welch_p(times_a, times_b)))
    return comparisons


def comparison_table(comparisons: list[Comparison]) -> str:
    def mark(p: float) -> str:
        return " *" if p < ALPHA else "  "

    header = (f"{'family':<12} {'robot':<10} {'params':<34} {'A ok/n':>8} {'B ok/n':>8} {'diff':>6} {'p':>7}   "
              f"{'A mean s':>8} {'B mean s':>8} {'p':>7}")
    lines = [header, "-" * len(header)]
    for c in comparisons:
        family, robot, params = c.group
        lines.append(f"{family[:12]:<12} {robot[:10]:<10} {params[:34]:<34} {f'{c.a[0]}/{c.a[1]}':>8} "
                     f"{f'{c.b[0]}/{c.b[1]}':>8} {100 * c.rate_difference:>+5.0f}% {c.rate_p:>7.3f}{mark(c.rate_p)} "
                     f"{c.mean_a:>8.1f} {c.mean_b:>8.1f} {c.time_p:>7.3f}{mark(c.time_p)}")
    lines.append(f"* significant at {ALPHA:g} (success: Fisher's exact test; time: Welch's t-test); "
                 "diff = B - A")
    return "\n".join(lines)
