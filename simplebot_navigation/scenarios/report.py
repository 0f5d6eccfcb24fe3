"""The results of a scenario as a table, as JSON, and as a PNG of the trajectories over the world."""

from __future__ import annotations

import json
import math
from dataclasses import asdict

import numpy as np

from simplebot_navigation.sim.world import Cylinder, World
from simplebot_navigation.scenarios.runner import GoalResult, ScenarioOptions

COLUMNS = [  # header, width, cell
    ("run", 3, lambda r: f"{r.run + 1}"),
    ("goal", 14, lambda r: r.goal[:14]),
    ("status", 9, lambda r: r.status),
    ("ok", 4, lambda r: "yes" if r.success else "NO"),
    ("time s", 7, lambda r: f"{r.time_s:.1f}"),
    ("budget", 6, lambda r: f"{r.budget_s:.0f}"),
    ("path m", 6, lambda r: f"{r.path_length:.1f}"),
    ("line m", 6, lambda r: f"{r.straight_line:.1f}"),
    ("ratio", 5, lambda r: f"{r.path_length / r.straight_line:.2f}" if r.straight_line > 1e-6 else "-"),
    ("t/(L/v)", 7, lambda r: f"{r.time_ratio:.2f}" if math.isfinite(r.time_ratio) else "-"),
    ("coll", 4, lambda r: f"{r.collisions}"),
    ("struck", 6, lambda r: f"{r.struck_standing}"),
    ("clear m", 7, lambda r: f"{r.min_clearance:.2f}"),
    ("replans", 7, lambda r: "-" if r.replans is None else f"{r.replans}"),
    ("recov", 5, lambda r: "-" if r.recoveries is None else f"{r.recoveries}"),
    ("cyc p95 ms", 10, lambda r: f"{r.cycle_p95_ms:.1f}" if r.cycle_p95_ms is not None else "-"),
    ("missed", 6, lambda r: f"{r.cycles_missed}" if r.cycles_missed is not None else "-"),
]


def summary(results: list[GoalResult]) -> dict:
    ok = [r for r in results if r.success]
    return {
        "goals": len(results),
        "succeeded": len(ok),
        "success_rate": len(ok) / len(results) if results else math.nan,
        "mean_time_s": float(np.mean([r.time_s for r in ok])) if ok else math.nan,
        "mean_time_ratio": float(np.mean([r.time_ratio for r in ok])) if ok else math.nan,
        "collisions": sum(r.collisions for r in results),
        "struck_standing": sum(r.struck_standing for r in results),
        "min_clearance": min((r.min_clearance for r in results), default=math.nan),
        "recoveries": sum(r.recoveries or 0 for r in results),
        "challenge_score": float(np.mean([r.challenge_score for r in results])) if results else math.nan,
    }


def table(results: list[GoalResult]) -> str:
    lines = ["  ".join(f"{name:>{width}}" for name, width, _ in COLUMNS)]
    lines.append("  ".join("-" * width for _, width, _ in COLUMNS))
    for r in results:
        lines.append("  ".join(f"{cell(r):>{width}}" for _, width, cell in COLUMNS))
        if not r.success:
            lines.append(f"{'':5}-> {'; '.join(r.failures)}")
    s = summary(results)
    lines.append(f"success {s['succeeded']}/{s['goals']} ({100 * s['success_rate']:.0f} %), "
                 f"mean time to goal {s['mean_time_s']:.1f} s sim ({s['mean_time_ratio']:.2f} x path / max_vel_x), "
                 f"collisions while moving {s['collisions']}, struck while standing {s['struck_standing']}, "
                 f"min clearance {s['min_clearance']:.2f} m, recoveries {s['recoveries']}, "
                 f"BARN challenge score {s['challenge_score']:.3f}")
    located = [r.localization for r in results if r.localization]
    if located:
        samples = sum(e.samples for e in located)
        rms = math.sqrt(sum(e.samples * e.position_rms ** 2 for e in located) / samples)
        yaw = math.sqrt(sum(e.samples * e.yaw_rms ** 2 for e in located) / samples)
        worst_p95, worst = max(e.position_p95 for e in located), max(e.position_max for e in located)
        lines.append(f"amcl against ground truth: {100 * rms:.1f} cm RMS, worst goal's p95 {100 * worst_p95:.1f} cm, "
                     f"max {100 * worst:.1f} cm, yaw {math.degrees(yaw):.2f} deg RMS ({samples} poses)")
    return "\n".join(lines)


def finite(value):
    """For strict JSON: an infinite clearance (nothing in the world) or an undefined mean become null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    return value


def write_json(path: str, options: ScenarioOptions, results: list[GoalResult]) -> None:
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(finite({"options": asdict(options), "summary": summary(results),
                          "results": [r.to_dict() for r in results]}), handle, indent=1, allow_nan=False)


def plot(path: str, world: World, results: list[GoalResult], title: str) -> None:
    """Obstacles in grey, the start as a black triangle, goals as arrows, one colour per goal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    xmin, ymin, xmax, ymax = world.bounds()
    for r in results:
        traj = np.asarray(r.trajectory)
        xmin, xmax = min(xmin, r.x, traj[:, 1].min()), max(xmax, r.x, traj[:, 1].max())
        ymin, ymax = min(ymin, r.y, traj[:, 2].min()), max(ymax, r.y, traj[:, 2].max())
    width = 10.0
    fig, ax = plt.subplots(figsize=(width, max(3.0, width * (ymax - ymin) / max(xmax - xmin, 1e-6)) + 0.8))
    for _, shape in world.obstacles():
        if isinstance(shape, Cylinder):
            ax.add_patch(Circle(shape.center, shape.radius, color="0.45"))
            continue
        ax.add_patch(Polygon(shape.corners(), closed=True, color="0.45"))
    start = world.start
    ax.plot(start.x, start.y, marker=(3, 0, math.degrees(start.yaw) - 90), color="black", markersize=12,
            linestyle="none", label="start")
    colours = plt.get_cmap("tab10")
    names = list(dict.fromkeys(r.goal for r in results))
    for r in results:
        colour = colours(names.index(r.goal) % 10)
        traj = np.asarray(r.trajectory)
        ax.plot(traj[:, 1], traj[:, 2], color=colour, linewidth=1.2, linestyle="-" if r.success else "--",
                label=None if r.run else f"{r.goal}{'' if r.success else ' (failed)'}")
        if not r.success:
            ax.plot(traj[-1, 1], traj[-1, 2], marker="x", color="red", markersize=9)
    for name in names:
        r = next(r for r in results if r.goal == name)
        colour = colours(names.index(name) % 10)
        ax.arrow(r.x, r.y, 0.5 * math.cos(r.yaw), 0.5 * math.sin(r.yaw), width=0.06, color=colour)
        ax.annotate(name, (r.x, r.y), textcoords="offset points", xytext=(6, 6), fontsize=8, color=colour)
    ax.set_xlim(xmin - 0.5, xmax + 0.5)
    ax.set_ylim(ymin - 0.5, ymax + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
