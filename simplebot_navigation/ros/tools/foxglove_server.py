"""The Foxglove WebSocket protocol (ws-protocol v1, as the Foxglove app speaks it), server side, with the checks a
server on the robot's computer needs: the handshake's ``Origin`` must be allowed and its ``Host`` must name this
server. Browsers let any page open a WebSocket to localhost; without these checks any web page (or a DNS-rebinding
one) open on the robot's computer could subscribe to everything and publish goals.

What it speaks: serverInfo, advertise and status to clients; message data and time as binary frames; subscribe,
unsubscribe, client advertise/unadvertise and client message data from them. It runs an asyncio loop on a thread
of its own and tells its owner what clients do through ``post((kind, client_id, args))``, from that thread; the
owner's calls (add_channel, log, broadcast_time, status, allow_origins) may come from any thread.

Clients are strangers: every id a client gives (subscription and channel ids) must be a uint32, every name a string of
at most MAX_NAME characters; anything else is refused to that client with an error status and reported to the owner
through ``refused(kind, text)``, which the owner may throttle per kind. A client whose frames cannot be queued is
closed; the others are served on.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import struct
import threading
from dataclasses import dataclass, field
from typing import Callable, Iterable

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request

from simplebot_navigation.web_host import is_own_host, machine_names

SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")
MESSAGE_DATA, TIME = 1, 2                  # binary opcodes, server to client
CLIENT_MESSAGE_DATA = 1                    # binary opcode, client to server
STATUS_INFO, STATUS_WARNING, STATUS_ERROR = 0, 1, 2
#: frames queued for one client before the oldest message data is dropped (a slow client must not grow memory)
MAX_BACKLOG = 512
MAX_CLIENT_FRAME = 1 << 20
#: the longest topic, encoding or schema name a client may advertise
MAX_NAME = 1024
UINT32_MAX = 2**32 - 1
#: subscription and advertisement changes a client may make: a burst (the app opening a layout subscribes to a few
#: dozen topics at once), then so many a second. Each change costs the bridge a ROS subscription made or destroyed,
#: which every node on the graph hears about: a client that churns them must not load the robot's computer.
CHANGE_BURST, CHANGES_PER_S = 200, 20.0
#: the operations that change subscriptions or advertisements, and the list each one's changes are in
CHANGE_ITEMS = {"subscribe": "subscriptions", "unsubscribe": "subscriptionIds", "advertise": "channels",
                "unadvertise": "channelIds"}


@dataclass
class _Client:
    id: int
    ws: ServerConnection
    queue: asyncio.Queue = field(default_factory=lambda: asyncio.Queue(MAX_BACKLOG))
    subscriptions: dict[int, int] = field(default_factory=dict)     # subscription id -> channel id
    advertised: set[int] = field(default_factory=set)               # the client's own channel ids
    dropped: int = 0
    budget: float = CHANGE_BURST                                     # subscription changes it may still make
    budget_time: float = 0.0
    told_over_budget: float = -1.0

    def may_change(self, now: float, changes: int) -> bool:
        """Take ``changes`` subscription or advertisement changes from the client's budget, if it has them."""
        self.budget = min(CHANGE_BURST, self.budget + (now - self.budget_time) * CHANGES_PER_S)
        self.budget_time = now
        if self.budget < changes:
            return False
        self.budget -= changes
        return True

    def put(self, frame) -> None:
        if self.queue.full():
            self.queue.get_nowait()
            self.dropped += 1
        self.queue.put_nowait(frame)


class FoxgloveServer:
    """One Foxglove WebSocket server; OSError when it cannot listen on host:port (port 0: a free one)."""

    def __init__(self, name: str, host: str, port: int, post: Callable[[tuple], None],
                 allowed_origins: tuple[str, ...], refused: Callable[[str, str], None],
                 metadata: dict[str, str] | None = None):
        self._post, self._refused = post, refused
        self.allow_origins(allowed_origins)
        self._host = host
        self._machine_names = machine_names(host)
        self._info = {"op": "serverInfo", "name": name, "capabilities": ["clientPublish", "time"],
                      "supportedEncodings": ["cdr", "json"], "metadata": metadata or {}, "sessionId": name}
        self._channels: dict[int, dict] = {}
        self._clients: dict[int, _Client] = {}
        self._ids = itertools.count(1)
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._server = None
        self._thread = threading.Thread(target=self._run, args=(port,), name="foxglove-server", daemon=True)
        self._thread.start()
        self._ready.wait()
        if self._error is not None:
            raise OSError(f"cannot listen on {host}:{port}: {self._error}") from self._error

    @property
    def port(self) -> int:
        return self._server.sockets[0].getsockname()[1]

    # -- the owner's side (any thread) --------------------------------------------------------------
    def add_channel(self, topic: str, encoding: str, schema_name: str, schema: str, schema_encoding: str) -> int:
        channel = {"id": next(self._ids), "topic": topic, "encoding": encoding, "schemaName": schema_name,
                   "schema": schema, "schemaEncoding": schema_encoding}
        self._loop.call_soon_threadsafe(self._advertise, channel)
        return channel["id"]

    def log(self, channel_id: int, data: bytes, log_time: int) -> None:
        self._loop.call_soon_threadsafe(self._fan_out, channel_id, bytes(data), log_time)

    def broadcast_time(self, timestamp_ns: int) -> None:
        frame = struct.pack("<BQ", TIME, timestamp_ns)
        self._loop.call_soon_threadsafe(self._to_clients, lambda client: (frame,))

    def allow_origins(self, origins: tuple[str, ...]) -> None:
        """The browser pages whose handshakes are taken from now on (those connected stay)."""
        self._allowed_origins = frozenset(o.rstrip("/") for o in origins)

    def status(self, client_id: int, level: int, message: str) -> None:
        """A status message to one client (the app shows it in its problems panel)."""
        frame = json.dumps({"op": "status", "level": level, "message": message})
        self._loop.call_soon_threadsafe(lambda: self._clients[client_id].put(frame)
                                        if client_id in self._clients else None)

    def stop(self) -> None:
        if self._thread.is_alive():
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=5.0)

    # -- the server's thread ------------------------------------------------------------------------
    def _run(self, port: int) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._server = self._loop.run_until_complete(self._listen(port))
        except (OSError, ValueError) as err:    # a port in use, an address that is not this machine's
            self._error = err
            self._ready.set()
            return
        self._ready.set()
        try:
            self._loop.run_forever()
        finally:
            self._server.close()
            self._loop.run_until_complete(self._server.wait_closed())
            self._loop.close()

    async def _listen(self, port: int):
        return await serve(self._serve, self._host, port, subprotocols=list(SUBPROTOCOLS),
                           process_request=self._check, max_size=MAX_CLIENT_FRAME, compression=None)

    def _check(self, connection: ServerConnection, request: Request):
        """Refuse a handshake from a page of a foreign origin, or addressed to a foreign name (DNS rebinding)."""
        hosts, origins = request.headers.get_all("Host"), request.headers.get_all("Origin")
        host, origin = (hosts or [""])[0], (origins or [None])[0]
        if len(hosts) != 1 or len(origins) > 1:
            why = "a handshake needs exactly one Host and at most one Origin header"
        elif not is_own_host(host, self._host, self.port, self._machine_names):
            why = f"Host {host!r} is not this server"
        elif origin is not None and origin.rstrip("/") not in self._allowed_origins:
            why = f"Origin {origin!r} is not allowed (foxglove_allowed_origins)"
        else:
            return None
        self._refused("handshake", f"refused a WebSocket handshake from {connection.remote_address[0]}: {why}")
        return connection.respond(403, why + "\n")

    def _advertise(self, channel: dict) -> None:
        self._channels[channel["id"]] = channel
        frame = json.dumps({"op": "advertise", "channels": [channel]})
        self._to_clients(lambda client: (frame,))

    def _fan_out(self, channel_id: int, data: bytes, log_time: int) -> None:
        self._to_clients(lambda client: [struct.pack("<BIQ", MESSAGE_DATA, subscription, log_time) + data
                                         for subscription, channel in client.subscriptions.items()
                                         if channel == channel_id])

    def _to_clients(self, frames: Callable[[_Client], Iterable]) -> None:
        """Queue ``frames(client)`` for every client, each on its own: one that fails is closed, and the clients
        after it still get theirs."""
        for client in list(self._clients.values()):
            try:
                for frame in frames(client):
                    client.put(frame)
            except Exception as err:  # noqa: BLE001 - whatever one client's frames raise, the others are served
                del self._clients[client.id]
                self._refused("client", f"closed Foxglove client {client.id}: cannot send it a frame "
                                        f"({type(err).__name__}: {err})")
                self._loop.create_task(client.ws.close(1011, "the server cannot send to this client"))

    async def _serve(self, ws: ServerConnection) -> None:
        client = _Client(next(self._ids), ws, budget_time=self._loop.time())
        self._clients[client.id] = client
        client.put(json.dumps(self._info))
        client.put(json.dumps({"op": "advertise", "channels": list(self._channels.values())}))
        sender = asyncio.get_running_loop().create_task(self._send(client))
        try:
            async for frame in ws:
                self._receive(client, frame)
        except ConnectionClosed:
            pass
        finally:
            sender.cancel()
            self._clients.pop(client.id, None)
            for channel in client.subscriptions.values():
                self._post(("unsubscribe", client.id, channel))
            for channel in client.advertised:
                self._post(("unadvertise", client.id, channel))

    @staticmethod
    async def _send(client: _Client) -> None:
        try:
            while True:
                await client.ws.send(await client.queue.get())
        except ConnectionClosed:
            pass

    def _receive(self, client: _Client, frame) -> None:
        """One frame from a client; anything malformed is answered with a status message, never acted on."""
        if isinstance(frame, bytes):
            if len(frame) < 5 or frame[0] != CLIENT_MESSAGE_DATA:
                return self._tell(client, f"binary frame with opcode {frame[:1].hex() or 'none'} ignored")
            channel = struct.unpack_from("<I", frame, 1)[0]
            if channel not in client.advertised:
                return self._tell(client, f"message on channel {channel}, which this client has not advertised")
            return self._post(("data", client.id, (channel, frame[5:])))
        try:
            message = json.loads(frame)
        except (ValueError, RecursionError) as err:
            return self._reject(client, f"a request that is not JSON ({type(err).__name__}: {err}) ignored")
        op = message.get("op") if isinstance(message, dict) else None
        if not isinstance(op, str) or op not in CHANGE_ITEMS:
            return self._tell(client, f"operation {_short(op)} is not supported here")
        items = message.get(CHANGE_ITEMS[op])
        if not isinstance(items, list):
            return self._reject(client, f"{op}: {CHANGE_ITEMS[op]!r} must be a list; ignored")
        if not self._within_budget(client, op, max(1, len(items))):
            return
        take = {"subscribe": self._subscribe, "unsubscribe": self._unsubscribe, "advertise": self._advertised,
                "unadvertise": self._unadvertised}[op]
        for item in items:
            try:
                take(client, item)
            except ValueError as err:
                self._reject(client, f"{op}: {err}; ignored")

    def _subscribe(self, client: _Client, item) -> None:
        subscription, channel = _uint32(_field(item, "id"), "subscription id"), \
            _uint32(_field(item, "channelId"), "channel id")
        if channel not in self._channels:
            return self._tell(client, f"subscription {subscription}: no channel {channel}")
        if subscription in client.subscriptions:
            return self._tell(client, f"subscription {subscription} is already in use")
        client.subscriptions[subscription] = channel
        self._post(("subscribe", client.id, channel))

    def _unsubscribe(self, client: _Client, item) -> None:
        channel = client.subscriptions.pop(_uint32(item, "subscription id"), None)
        if channel is not None:
            self._post(("unsubscribe", client.id, channel))

    def _advertised(self, client: _Client, item) -> None:
        channel = _uint32(_field(item, "id"), "channel id")
        topic, encoding = _name(_field(item, "topic"), "topic"), _name(_field(item, "encoding"), "encoding")
        schema = _name(item.get("schemaName", ""), "schemaName")
        client.advertised.add(channel)
        self._post(("advertise", client.id, (channel, topic, encoding, schema)))

    def _unadvertised(self, client: _Client, item) -> None:
        channel = _uint32(item, "channel id")
        client.advertised.discard(channel)
        self._post(("unadvertise", client.id, channel))

    def _within_budget(self, client: _Client, op: str, changes: int) -> bool:
        now = self._loop.time()
        if client.may_change(now, changes):
            return True
        if now - client.told_over_budget >= 1.0:
            client.told_over_budget = now
            self._tell(client, f"{op} ignored: more than {CHANGES_PER_S:g} subscription or advertisement changes a "
                               f"second (after a burst of {CHANGE_BURST})")
        return False

    @staticmethod
    def _tell(client: _Client, message: str, level: int = STATUS_WARNING) -> None:
        client.put(json.dumps({"op": "status", "level": level, "message": message}))

    def _reject(self, client: _Client, message: str) -> None:
        """A malformed request: an error status to the client, and a line to the owner (which may throttle it)."""
        self._tell(client, message, STATUS_ERROR)
        self._refused("request", f"Foxglove client {client.id}: {message}")


def _field(item, key: str):
    if not isinstance(item, dict) or key not in item:
        raise ValueError(f"an item without {key!r} ({_short(item)})")
    return item[key]


def _uint32(value, what: str) -> int:
    """A client's id: an integer 0..2**32 - 1, as the protocol's binary frames carry it."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= UINT32_MAX:
        raise ValueError(f"{what} {_short(value)} is not a uint32 (an integer 0..{UINT32_MAX})")
    return value


def _name(value, what: str) -> str:
    if not isinstance(value, str) or len(value) > MAX_NAME:
        raise ValueError(f"{what} {_short(value)} is not a string of at most {MAX_NAME} characters")
    return value


def _short(value, width: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."
