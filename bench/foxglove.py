"""Foxglove bridge load: its CPU idle, and with the shipped layout's topics subscribed while the robot drives.

    python bench/foxglove.py [--seconds 20]

Starts ``python -m simplebot_navigation.launch navigation world:=lab rtf:=1 foxglove:=true`` (every node its
own process) and measures the foxglove_bridge process (utime + stime of /proc/<pid>/stat) over two phases:

  idle     no client: the bridge only follows /clock for the app's time.
  layout   a WebSocket client, as the Foxglove app with config/simplebot.foxglove.json open, subscribed to
           every topic the layout shows, while the robot drives to the lab's library; messages and bytes
           are the message-data frames it receives.
  storm    the same, plus a second client that subscribes to every channel and unsubscribes again, as fast as
           the server answers (a hostile or broken client).

"missed" is move_base's own count of control cycles that overran their period during the phase (its
/diagnostics, missed_total): what the bridge's load may cost the robot.

CPU % is of one core per wall second; "/sim s" per simulated second, which a simulator falling behind real
time does not flatter. load1 is the 1-minute load average at the start and end of each phase.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import re
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[0] = str(ROOT)  # not bench/: this file's name would shadow the foxglove package

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

from websockets.exceptions import ConnectionClosed  # noqa: E402
from websockets.sync.client import ClientConnection, connect  # noqa: E402

from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402

from simplebot_navigation.scenarios.campaign.execution import domain_lease  # noqa: E402
from simplebot_navigation.scenarios.process_session import ProcessSession  # noqa: E402
from simplebot_navigation.testing.proc_stats import cpu_seconds, loadavg  # noqa: E402

LAYOUT = ROOT / "config" / "simplebot.foxglove.json"
SUBPROTOCOL = "foxglove.sdk.v1"
GOAL = "library"
SETTLE_S = 2.0      # wall seconds after subscribing, so the first (latched, whole-costmap) messages are behind
START_TIMEOUT_S = 240.0


def layout_topics() -> set[str]:
    """What the layout's panels subscribe to: the 3D panel's visible topics and the transforms it draws them
    with, the plotted message paths' topics, and the log panel's /rosout."""
    panels = json.loads(LAYOUT.read_text())["configById"]
    shown = {topic for topic, settings in panels["3D!simplebot"]["topics"].items() if settings["visible"]}
    plotted = {series["value"].split(".")[0] for series in panels["Plot!cmd_vel"]["paths"]}
    return shown | plotted | {"/tf", "/tf_static", "/rosout"}


class Client:
    """The app's side of the protocol: channels from the advertisements, then subscriptions whose
    message-data frames (opcode 1) a thread counts."""

    def __init__(self, ws: ClientConnection):
        self.ws = ws
        self.channels: dict[str, int] = {}
        self.messages = self.bytes = 0

    def wait_for(self, topics: set[str], wall_s: float) -> None:
        deadline = time.monotonic() + wall_s
        while not topics <= set(self.channels) and time.monotonic() < deadline:
            try:
                self._handle(self.ws.recv(timeout=0.5))
            except TimeoutError:
                pass

    def subscribe(self, topics: set[str]) -> None:
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": self.channels[t]} for i, t in enumerate(sorted(topics))]}))
        threading.Thread(target=self._receive, daemon=True).start()

    def _receive(self) -> None:
        try:
            for frame in self.ws:
                self._handle(frame)
        except ConnectionClosed:   # our close, which the server leaves unanswered
            pass

    def _handle(self, frame: str | bytes) -> None:
        if isinstance(frame, str):
            message = json.loads(frame)
            if message["op"] == "advertise":
                self.channels.update({c["topic"]: c["id"] for c in message["channels"]})
        elif frame[0] == 1:
            self.messages += 1
            self.bytes += len(frame)


class MissedCycles:
    """move_base's running count of overrun control cycles, from its /diagnostics (once a second)."""

    def __init__(self, session: ProcessSession):
        self.total = 0
        session.client.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            if "missed_total" in values:
                self.total = int(values["missed_total"])


def storm(url: str, stop: threading.Event) -> None:
    """A client that subscribes to every channel and unsubscribes again, as fast as the server takes it."""
    with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=30, max_size=None) as ws:
        client = Client(ws)
        deadline = time.monotonic() + 10.0
        while not client.channels and time.monotonic() < deadline:
            client.wait_for({"/tf"}, 1.0)
        ids = itertools.count(1000)
        while not stop.is_set():
            subscriptions = [{"id": next(ids), "channelId": channel} for channel in client.channels.values()]
            ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
            ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": [s["id"] for s in subscriptions]}))
            try:
                while True:
                    ws.recv(timeout=0)
            except TimeoutError:
                pass


def measure(session: ProcessSession, pid: int, phase: str, seconds: float, missed: MissedCycles,
            client: Client | None = None) -> str:
    """Spin the session for wall seconds; the table row of the bridge's CPU, the client's traffic and
    move_base's missed cycles."""
    load0, cpu0, wall0, sim0, missed0 = loadavg(), cpu_seconds(pid), time.monotonic(), session.time, missed.total
    counts0 = (client.messages, client.bytes) if client else (0, 0)
    session.spin_wall(seconds)
    session.spin_wall(1.5)   # the last diagnostics of the phase
    cpu, wall, sim = cpu_seconds(pid) - cpu0, time.monotonic() - wall0, session.time - sim0
    messages, size = ((client.messages - counts0[0], client.bytes - counts0[1]) if client else (0, 0))
    return (f"{phase:7} {100 * cpu / wall:8.1f} {100 * cpu / sim if sim > 0 else float('nan'):7.1f} "
            f"{messages / wall:7.0f} {size / wall / 1e3:7.1f} {missed.total - missed0:7d} {load0:>6}/{loadavg()}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="wall seconds of each phase")
    args = parser.parse_args()
    with domain_lease(os.getpid() % 100, None) as domain:
        os.environ["ROS_DOMAIN_ID"] = str(domain)    # a domain of its own, for the launched nodes too
        run_phases(args.seconds)


def run_phases(seconds: float) -> None:
    with ProcessSession("lab", rtf=1.0, foxglove_port=0) as session:
        session.wait_ready(wall_timeout_s=START_TIMEOUT_S)
        url = re.compile(r"Foxglove WebSocket server on (ws://\S+)")
        session.spin_wall(START_TIMEOUT_S, lambda: url.search(session.log_text()) is not None)
        pid = session.node_pid("foxglove_bridge")
        missed = MissedCycles(session)
        rows = [measure(session, pid, "idle", seconds, missed)]
        address = url.search(session.log_text()).group(1)
        with connect(address, subprotocols=[SUBPROTOCOL], open_timeout=30, max_size=None) as ws:
            client = Client(ws)
            topics = layout_topics()
            client.wait_for(topics, 10.0)
            topics &= set(client.channels)
            client.subscribe(topics)
            run = session.send_goal(next(g for g in session.world.goals if g.name == GOAL))
            session.spin_wall(SETTLE_S)
            rows.append(measure(session, pid, "layout", seconds, missed, client))
            stop = threading.Event()
            stormer = threading.Thread(target=storm, args=(address, stop), daemon=True)
            stormer.start()
            rows.append(measure(session, pid, "storm", seconds, missed, client))
            stop.set()
            stormer.join(timeout=10.0)
    missing = layout_topics() - topics
    print(f"layout: {len(topics)} topics subscribed" + (f", not offered: {', '.join(sorted(missing))}" if missing
                                                          else "") + f"; goal {GOAL}: {run.status or 'still driving'}")
    print(f"{'phase':7} {'CPU %':>8} {'/sim s':>7} {'msg/s':>7} {'kB/s':>7} {'missed':>7} load1 start/end")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
