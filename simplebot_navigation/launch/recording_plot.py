"""Plot a run recorded to MCAP (ros/tools/recorder.py): global costmap, odometry and ground truth,
every plan, the goals. `python -m simplebot_navigation.launch.record --plot run.mcap run.png`."""

from __future__ import annotations

import math
from pathlib import Path

from simplebot_navigation.ros.conversions import yaw_of

GLOBAL_COSTMAP = "/global_costmap/costmap"
PLAN_TOPICS = {"global plan": "/move_base/GlobalPlanner/plan", "local plan": "/move_base/TebLocalPlannerROS/local_plan"}
ODOM = "/simplebot_controller/odom"
GROUND_TRUTH = "/simplebot/ground_truth"
GOAL_TOPICS = ("/move_base_simple/goal", "/move_base/current_goal")


def _read_recording(mcap_path: str):
    """(costmap grid or None, tracks, plans, goals, stamps) of the topics plotted, as the run ends."""
    import numpy as np
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    grid = None
    tracks: dict[str, list] = {ODOM: [], GROUND_TRUTH: []}
    plans: dict[str, list] = {name: [] for name in PLAN_TOPICS}
    goals = []
    stamps = []
    topics = [GLOBAL_COSTMAP, GLOBAL_COSTMAP + "_updates", *PLAN_TOPICS.values(), ODOM, GROUND_TRUTH, *GOAL_TOPICS]
    try:
        with open(mcap_path, "rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            messages = [(channel.topic, msg) for _, channel, _, msg in reader.iter_decoded_messages(topics=topics)]
    except FileNotFoundError as err:
        raise FileNotFoundError(f"--plot: no such recording {mcap_path}") from err
    for topic, msg in messages:
        if topic == GLOBAL_COSTMAP:
            info = msg.info
            grid = {"cells": np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width).copy(),
                    "resolution": info.resolution, "origin": (info.origin.position.x, info.origin.position.y)}
        elif topic == GLOBAL_COSTMAP + "_updates" and grid is not None:
            window = np.asarray(msg.data, dtype=np.int8).reshape(msg.height, msg.width)
            grid["cells"][msg.y:msg.y + msg.height, msg.x:msg.x + msg.width] = window
        elif topic in tracks:
            p = msg.pose.pose.position
            tracks[topic].append((p.x, p.y))
            stamps.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
        elif topic in GOAL_TOPICS:
            goal = (msg.pose.position.x, msg.pose.position.y, yaw_of(msg.pose.orientation))
            if not goals or goals[-1] != goal:
                goals.append(goal)
        else:
            name = next(n for n, t in PLAN_TOPICS.items() if t == topic)
            plans[name].append(np.array([(p.pose.position.x, p.pose.position.y) for p in msg.poses]).reshape(-1, 2))
    if not messages:
        raise ValueError(f"--plot: {mcap_path} has none of the topics to plot ({', '.join(topics)})")
    return grid, tracks, plans, goals, stamps


def plot_recording(mcap_path: str, png_path: str) -> dict:
    """Render the recorded run: global costmap, odometry (and ground truth), every plan, the goals."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    grid, tracks, plans, goals, stamps = _read_recording(mcap_path)
    everything = [np.array(t) for t in tracks.values() if t] + [np.array(g)[:2].reshape(1, 2) for g in goals]
    if everything:  # frame the run, not the whole costmap
        pts = np.vstack(everything)
        lo, hi = pts.min(axis=0) - 2.0, pts.max(axis=0) + 2.0
    elif grid is not None:
        lo = np.array(grid["origin"])
        hi = lo + grid["resolution"] * np.array(grid["cells"].shape[::-1])
    else:
        lo, hi = np.array([-5.0, -5.0]), np.array([5.0, 5.0])
    aspect = min(2.0, max(0.5, (hi[1] - lo[1]) / (hi[0] - lo[0])))
    fig, ax = plt.subplots(figsize=(9, 1.5 + 7.5 * aspect), dpi=110)
    if grid is not None:
        cells = grid["cells"].astype(float)
        shown = np.ma.masked_where(cells == 0, np.where(cells < 0, np.nan, cells))
        h, w = cells.shape
        ox, oy = grid["origin"]
        res = grid["resolution"]
        extent = (ox, ox + w * res, oy, oy + h * res)
        ax.imshow(np.where(cells < 0, 1.0, np.nan), origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=4,
                  interpolation="nearest")
        ax.imshow(shown, origin="lower", extent=extent, cmap="magma_r", vmin=1, vmax=100, interpolation="nearest")
    for name, colour, width in (("local plan", "tab:blue", 0.6), ("global plan", "tab:green", 0.8)):
        for path in plans[name]:
            if len(path):
                ax.plot(path[:, 0], path[:, 1], color=colour, lw=width, alpha=0.25)
        if plans[name] and len(plans[name][-1]):
            ax.plot(plans[name][-1][:, 0], plans[name][-1][:, 1], color=colour, lw=2, label=f"{name} (last)")
    for topic, style, label in ((GROUND_TRUTH, dict(color="0.4", ls="--", lw=1.2), "ground truth"),
                                (ODOM, dict(color="tab:red", lw=2), "odometry")):
        if tracks[topic]:
            xy = np.array(tracks[topic])
            ax.plot(xy[:, 0], xy[:, 1], label=label, **style)
    if tracks[ODOM]:
        ax.plot(*tracks[ODOM][0], "o", color="tab:red", ms=7, label="start")
    for x, y, yaw in goals:
        ax.annotate("", xy=(x + 0.6 * math.cos(yaw), y + 0.6 * math.sin(yaw)), xytext=(x, y),
                    arrowprops=dict(arrowstyle="-|>", color="crimson", lw=2))
        ax.plot(x, y, "x", color="crimson", ms=9)
    duration = (max(stamps) - min(stamps)) if stamps else 0.0
    ax.set_title(f"{Path(mcap_path).name}: {duration:.1f} s, {len(goals)} goal(s), "
                 f"{len(plans['global plan'])} global plans")
    ax.set_xlabel("x [m] (odom)")
    ax.set_ylabel("y [m] (odom)")
    ax.set_aspect("equal")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(png_path)
    plt.close(fig)
    return {"duration": duration, "goals": len(goals), "global_plans": len(plans["global plan"]),
            "odometry": len(tracks[ODOM]), "costmap": grid is not None}
