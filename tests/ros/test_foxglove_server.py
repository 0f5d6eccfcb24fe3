"""The Foxglove WebSocket server alone (no ROS): each client is served on its own."""

import json
import struct
import time

from websockets.exceptions import ConnectionClosedError
from websockets.sync.client import connect

from simplebot_navigation.ros.tools.foxglove_server import MESSAGE_DATA, FoxgloveServer


def subscribed_client(url: str, channel: int):
    ws = connect(url, subprotocols=["foxglove.websocket.v1"], open_timeout=10)
    assert json.loads(ws.recv(timeout=10))["op"] == "serverInfo"
    ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": channel}]}))
    return ws


def received(ws, server: FoxgloveServer, channel: int, wall_s: float = 20.0) -> bytes:
    """The next message data on subscription 7, logging until one comes (the subscription may still be on its way)."""
    deadline = time.monotonic() + wall_s
    while time.monotonic() < deadline:
        server.log(channel, b"hello", 1)
        try:
            frame = ws.recv(timeout=0.1)
        except TimeoutError:
            continue
        if isinstance(frame, bytes) and frame[0] == MESSAGE_DATA:
            assert struct.unpack_from("<I", frame, 1)[0] == 7
            return frame[13:]
    raise AssertionError("no message data within 20 s")


def test_a_client_whose_frames_fail_is_closed_and_the_clients_after_it_are_still_served():
    said: list[tuple[str, str]] = []
    server = FoxgloveServer("test", "127.0.0.1", 0, lambda event: None, (),
                            lambda kind, text: said.append((kind, text)))
    try:
        channel = server.add_channel("/chatter", "cdr", "std_msgs/msg/String", "string data\n", "ros2msg")
        url = f"ws://127.0.0.1:{server.port}"
        with subscribed_client(url, channel) as broken, subscribed_client(url, channel) as other:
            assert received(broken, server, channel) == b"hello" and received(other, server, channel) == b"hello"
            first = next(iter(server._clients.values()))    # first in the fan-out's order: the first connected

            def fails(frame):
                raise RuntimeError("this client's queue is broken")
            first.put = fails
            for _ in range(3):
                assert received(other, server, channel) == b"hello"
            try:
                while True:
                    broken.recv(timeout=10)
            except ConnectionClosedError as closed:
                assert closed.rcvd.code == 1011
        assert said == [("client", f"closed Foxglove client {first.id}: cannot send it a frame "
                                   "(RuntimeError: this client's queue is broken)")]
    finally:
        server.stop()
