"""Record every topic of a run to MCAP (as `ros2 bag record -a -s mcap` would), and plot a recorded run.

    python -m simplebot_navigation.launch navigation --record run.mcap      # with the launcher
    python -m simplebot_navigation.launch.record run.mcap                  # join a running system
    python -m simplebot_navigation.launch.record --plot run.mcap run.png   # map, trajectory, plans

Messages are written as they arrive on the wire (serialized CDR, no decoding), with
the ros2msg schemas rosbag2 writes, so Foxglove, `ros2 bag info/play` and the
`mcap` readers understand the file. Hidden topics (a name part starting with `_`,
such as action internals) are left out, as rosbag2 does by default.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import re
import sys
import time
from pathlib import Path

import yaml
from mcap.writer import CompressionType, Writer
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args

from simplebot_navigation.launch.loader import LaunchError, NodeSpec
from simplebot_navigation.ros.conversions import yaw_of

PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
              "int64", "uint64", "string", "wstring"}
SEPARATOR = "=" * 80
GLOBAL_COSTMAP = "/global_costmap/costmap"
PLAN_TOPICS = {"global plan": "/move_base/GlobalPlanner/plan", "local plan": "/move_base/TebLocalPlannerROS/local_plan"}
ODOM = "/simplebot_controller/odom"
GROUND_TRUTH = "/simplebot/ground_truth"
GOAL_TOPICS = ("/move_base_simple/goal", "/move_base/current_goal")
# rosbag2 writes an infinite QoS duration as this pair
_INFINITE_NS = 2**63 - 1
_INFINITE_SEC, _INFINITE_NSEC = 2147483647, 4294967295


# -- schemas ----------------------------------------------------------------------------------------
def _interface_dirs() -> list[Path]:
    """share/ folders that hold .msg files: this environment's, then those of a sourced ROS 2 install."""
    prefixes = [sys.prefix, *filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep))]
    return [Path(p) / "share" for p in prefixes]


def _msg_text(type_name: str) -> str:
    package, _, name = type_name.partition("/msg/")
    for share in _interface_dirs():
        path = share / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path.read_text(encoding="utf-8")
    raise FileNotFoundError(f"no definition {package}/msg/{name}.msg in "
                            + ", ".join(str(d) for d in _interface_dirs()))


def _field_types(text: str, package: str) -> list[str]:
    """Complex field types of a .msg text as pkg/msg/Name (constants and primitives left out)."""
    types = []
    for line in text.splitlines():
        words = line.split("#", 1)[0].split()
        if len(words) < 2 or "=" in words[1] or "=" in words[0]:
            continue
        base = re.sub(r"\[.*\]$", "", words[0]).split("<=")[0]
        if base in PRIMITIVES:
            continue
        parts = base.split("/")
        types.append(f"{parts[0]}/msg/{parts[-1]}" if len(parts) > 1 else f"{package}/msg/{base}")
    return types


def message_definition(type_name: str) -> str:
    """The ros2msg schema of a message type: its .msg text, then every type it uses, each once."""
    if "/msg/" not in type_name:
        raise ValueError(f"{type_name!r} is not a message type (pkg/msg/Name)")
    top = _msg_text(type_name)
    parts, seen = [top], {type_name}
    pending = _field_types(top, type_name.split("/")[0])
    while pending:
        dep = pending.pop(0)
        if dep in seen:
            continue
        seen.add(dep)
        text = _msg_text(dep)
        parts.append(f"{SEPARATOR}\nMSG: {dep}\n{text}")
        pending.extend(_field_types(text, dep.split("/")[0]))
    return "\n".join(p.rstrip("\n") for p in parts) + "\n"


def _hidden(topic: str) -> bool:
    return any(part.startswith("_") for part in topic.split("/"))


def recorder_spec(path: str):
    """The launcher's node entry for --record: runs Recorder as one more node of the launch file."""
    target = Path(path).expanduser().resolve()
    if not target.parent.is_dir():
        raise LaunchError(f"--record {path}: folder {target.parent} does not exist")
    if target.suffix != ".mcap":
        raise LaunchError(f"--record {path}: the file name must end in .mcap")
    return NodeSpec(pkg="python", type=f"{__name__}:Recorder", name="recorder", namespace="/", output="screen",
                    respawn=False, respawn_delay=0.0, required=False, parameters={"path": str(target)})


# -- recording --------------------------------------------------------------------------------------
class Recorder(Node):
    """Subscribes to each topic as it appears (every `discovery_period` s) and writes raw messages."""

    def __init__(self, path: str | None = None, **kwargs):
        super().__init__("recorder", **kwargs)
        self.writer = None
        path = self.declare_parameter("path", path or "").value
        period = self.declare_parameter("discovery_period", 0.5).value
        if not path:
            self.destroy_node()
            raise ValueError("recorder parameter 'path' (the .mcap file to write) is not set")
        if not (isinstance(period, (int, float)) and period > 0):
            self.destroy_node()
            raise ValueError(f"recorder parameter 'discovery_period' must be > 0 s, got {period!r}")
        self.path = path
        self.counts: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._skipped: set[str] = set()
        try:
            self._stream = open(path, "wb")  # noqa: SIM115 - closed in close()
        except OSError as err:
            self.destroy_node()
            raise ValueError(f"recorder cannot write {path}: {err.strerror}") from err
        self.writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self.writer.start(profile="ros2", library="simplebot_navigation")
        self.discover()
        self.create_timer(period, self.discover)
        self.get_logger().info(f"recording every topic to {path}")

    def _qos(self, topic: str) -> QoSProfile:
        """Match the publishers: latched if they all are (to get their last message), best effort if any is."""
        infos = self.get_publishers_info_by_topic(topic)
        latched = bool(infos) and all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
        best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
        return QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                          else ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)

    def _offered_qos(self, topic: str) -> str:
        """rosbag2's ``offered_qos_profiles`` channel metadata, so that ``ros2 bag play`` republishes latched
        topics (/tf_static, /robot_description, the costmaps) latched."""
        def duration(d) -> dict:
            ns = d.nanoseconds
            if ns >= _INFINITE_NS:
                return {"sec": _INFINITE_SEC, "nsec": _INFINITE_NSEC}
            return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}

        profiles = [{"history": int(q.history), "depth": int(q.depth), "reliability": int(q.reliability),
                     "durability": int(q.durability), "deadline": duration(q.deadline),
                     "lifespan": duration(q.lifespan), "liveliness": int(q.liveliness),
                     "liveliness_lease_duration": duration(q.liveliness_lease_duration),
                     "avoid_ros_namespace_conventions": bool(q.avoid_ros_namespace_conventions)}
                    for q in (info.qos_profile for info in self.get_publishers_info_by_topic(topic))]
        return yaml.safe_dump(profiles, sort_keys=False)

    def discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            # A topic only subscribers know of yet waits: its QoS comes from the publishers.
            if topic in self.counts or topic in self._skipped or _hidden(topic) or not self.count_publishers(topic):
                continue
            if len(types) != 1:
                self._skip(topic, f"it has more than one type ({', '.join(types)})")
                continue
            type_name = types[0]
            try:
                package, _, name = type_name.partition("/msg/")
                msg_class = getattr(importlib.import_module(f"{package}.msg"), name)
                if type_name not in self._schemas:
                    self._schemas[type_name] = self.writer.register_schema(
                        type_name, "ros2msg", message_definition(type_name).encode("utf-8"))
            except (ImportError, AttributeError, FileNotFoundError, ValueError) as err:
                self._skip(topic, f"type {type_name} is not available here: {err}")
                continue
            channel = self.writer.register_channel(topic, "cdr", self._schemas[type_name],
                                                   {"offered_qos_profiles": self._offered_qos(topic)})
            self.counts[topic] = 0
            self.create_subscription(msg_class, topic, lambda data, t=topic, c=channel: self._write(t, c, data),
                                     self._qos(topic), raw=True)

    def _skip(self, topic: str, why: str) -> None:
        self._skipped.add(topic)
        self.get_logger().warn(f"not recording {topic}: {why}")

    def _write(self, topic: str, channel: int, data: bytes) -> None:
        now = time.time_ns()
        self.writer.add_message(channel, log_time=now, data=data, publish_time=now, sequence=self.counts[topic])
        self.counts[topic] += 1

    def close(self) -> None:
        """Finish the file (summary and index): without it, readers must scan the whole file."""
        if self.writer is None:
            return
        self.writer.finish()
        self._stream.close()
        self.writer = None
        total = sum(self.counts.values())
        self.get_logger().info(f"recorded {total} messages on {len(self.counts)} topics to {self.path}")

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()



# -- plotting ---------------------------------------------------------------------------------------
def plot(mcap_path: str, png_path: str) -> dict:
    """Render the recorded run: global costmap, odometry (and ground truth), every plan, the goals."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
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


# -- command line -----------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    parser = argparse.ArgumentParser(prog="python -m simplebot_navigation.launch.record",
                                     description="record all topics to MCAP, or plot a recorded run")
    parser.add_argument("--plot", nargs=2, metavar=("RUN.mcap", "OUT.png"), help="render a recorded run to PNG")
    parser.add_argument("path", nargs="?", help="the .mcap file to record to (or the 'path' parameter)")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    if opts.plot:
        try:
            summary = plot(*opts.plot)
        except (FileNotFoundError, ValueError) as err:
            print(f"record: {err}", file=sys.stderr)
            return 2
        print(f"wrote {opts.plot[1]}: " + ", ".join(f"{k} {v}" for k, v in summary.items()))
        return 0

    from simplebot_navigation.ros.node_main import run_node
    return run_node("recorder", lambda: Recorder(path=opts.path), argv)


if __name__ == "__main__":
    sys.exit(main())
