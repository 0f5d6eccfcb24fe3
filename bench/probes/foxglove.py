"""Hostile Foxglove clients against the live bridge (issue 43): refusals in a row, ids that are not uint32, live
parameters out of bounds. Afterwards the bridge must be the process that started, and a second client must still
receive a channel. Nothing here publishes a goal or a command that reaches ROS: the robot stays standing.
"""

from __future__ import annotations

import json
import os
import struct
import time

SUBPROTOCOL = "foxglove.websocket.v1"
GOAL = "/move_base_simple/goal"
#: subscription ids that are not uint32, as JSON text
BAD_IDS = ("-1", str(2**33), "1e400")
#: a steady channel for the client that only watches
WATCHED = "/tf"


class _Client:
    """A Foxglove client: its channels by topic, the status messages it was told, message counts by subscription."""

    def __init__(self, port: int):
        from websockets.sync.client import connect

        self.ws = connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], open_timeout=10)
        self.channels: dict[str, int] = {}
        self.statuses: list[tuple[int, str]] = []
        self.received: dict[int, int] = {}
        self.wait(lambda: WATCHED in self.channels, 10.0)

    def read(self) -> None:
        while True:
            try:
                frame = self.ws.recv(timeout=0)
            except TimeoutError:
                return
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise":
                    self.channels.update({c["topic"]: c["id"] for c in message["channels"]})
                elif message["op"] == "status":
                    self.statuses.append((message["level"], message["message"]))
            elif frame[0] == 1:
                subscription = struct.unpack_from("<I", frame, 1)[0]
                self.received[subscription] = self.received.get(subscription, 0) + 1

    def wait(self, done, seconds: float) -> bool:
        """Read until done() or for ``seconds``; False also when the server closed the connection."""
        from websockets.exceptions import ConnectionClosed

        deadline = time.monotonic() + seconds
        try:
            while not done() and time.monotonic() < deadline:
                self.read()
                time.sleep(0.05)
            self.read()
        except ConnectionClosed:
            return False
        return done()

    def send(self, frame) -> None:
        self.ws.send(frame)

    def told(self, since: int) -> str:
        return "; ".join(text for _, text in self.statuses[since:]) or "nothing"

    def close(self) -> None:
        self.ws.close()


def _port(session) -> int:
    """The bridge's port, from the launcher's log line of its latest start."""
    lines = [line for line in session.log_text().splitlines() if "Foxglove WebSocket server on ws://" in line]
    return int(lines[-1].rsplit(":", 1)[1].strip())


def _refusals_in_a_row(port: int) -> list[tuple[str, str, str, bool]]:
    """Issue 43, probe 1: two refusals of different kinds in a row ended the bridge (rclpy's logging throttle)."""
    rows = []
    for what, advertised, payload in (
            ("advertise cmd_vel, then publish on it", ("/simplebot_controller/cmd_vel", "geometry_msgs/msg/Twist"),
             b'{"linear":{"x":0.3}}'),
            ("a goal that does not decode, then a wrong schema", (GOAL, "geometry_msgs/msg/PoseStamped"),
             b"not json")):
        client = _Client(port)
        try:
            client.send(json.dumps({"op": "advertise", "channels": [{"id": 9, "topic": advertised[0],
                                                                     "encoding": "json",
                                                                     "schemaName": advertised[1]}]}))
            client.send(b"\x01" + struct.pack("<I", 9) + payload)
            client.send(json.dumps({"op": "advertise", "channels": [{"id": 10, "topic": GOAL, "encoding": "json",
                                                                     "schemaName": "geometry_msgs/msg/Twist"}]}))
            client.send(b"\x01" + struct.pack("<I", 10) + b"{}")
            ok = client.wait(lambda: any("channel 10" in text for _, text in client.statuses), 15.0)
            rows.append((f"Foxglove: {what}", f"channel 9 {advertised[0]}", client.told(0)[:150], ok))
        finally:
            client.close()
    return rows


def _ids_not_uint32(port: int) -> list[tuple[str, str, str, bool]]:
    """Issue 43, probe 5: a subscription id of -1 or 2**33 stopped the fan-out to the clients after this one; 1e400
    closed the connection."""
    hostile = _Client(port)                 # connected first: first in the fan-out
    watcher = _Client(port)
    rows = []
    try:
        for bad in BAD_IDS:
            before = len(hostile.statuses)
            hostile.send(f'{{"op":"subscribe","subscriptions":[{{"id":{bad},"channelId":'
                         f'{hostile.channels[WATCHED]}}}]}}')
            told = hostile.wait(lambda: len(hostile.statuses) > before, 10.0)
            error = told and hostile.statuses[-1][0] == 2 and "uint32" in hostile.statuses[-1][1]
            rows.append(("Foxglove: subscription id", bad, hostile.told(before)[:150] if told else "connection closed",
                         error))
        watcher.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId":
                                                                       watcher.channels[WATCHED]}]}))
        got = watcher.wait(lambda: watcher.received.get(1, 0) >= 10, 15.0)
        rows.append(("Foxglove: a second client still receives", f"{WATCHED} after the hostile client's ids",
                     f"{watcher.received.get(1, 0)} messages in at most 15 s", got))
    finally:
        hostile.close()
        watcher.close()
    return rows


def _parameters(session) -> list[tuple[str, str, str, bool]]:
    from rclpy.parameter_client import AsyncParameterClient

    from bench.probes._common import set_parameter

    client = AsyncParameterClient(session.client, "/foxglove_bridge")
    rows = []
    for name, value in (("allowed_origins", "null"), ("allowed_origins", " ".join(["https://a.example"] * 65)),
                        ("port", 9000), ("host", "0.0.0.0")):
        ok, reason = set_parameter(session, client, name, value)
        rows.append((f"param set /foxglove_bridge {name}", repr(value)[:46], reason or "successful",
                     not ok and name in reason))
    return rows


def run(session) -> list[tuple[str, str, str, bool]]:
    pid, port = session.node_pid("foxglove_bridge"), _port(session)
    rows = _refusals_in_a_row(port) + _ids_not_uint32(port) + _parameters(session)
    session.spin_wall(2.0)        # a bridge that died would be in the launcher's log by now
    same = session.node_pid("foxglove_bridge")
    alive = same == pid and _running(pid)
    rows.append(("Foxglove: the bridge is the process that started", f"pid {pid}",
                 f"pid {same}, {'running' if alive else 'not running'}", alive))
    return rows


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True
