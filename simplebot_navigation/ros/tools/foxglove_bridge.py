"""Foxglove bridge: every topic of the run on a Foxglove WebSocket server, and goals back from the app.

Each topic of the graph (found as the MCAP recorder finds them, ros/tools/raw_topics.py) becomes a channel
with message encoding ``cdr`` and its ros2msg schema, so the Foxglove app decodes costmaps, plans,
scans, footprints and TF without configuration. A topic is subscribed in ROS only while some client
subscribes to its channel, raw (no decoding), and each message goes out as received, stamped with
this node's clock (simulated time under ``use_sim_time``), which the server also announces to the
app (the ``time`` capability). A latched topic's subscription is made anew for each client that
subscribes, so that it too gets the last message (those already subscribed get it once more).

Clients may publish, but only on the topics of CLIENT_TOPICS (RViz's and the 3D panel's goal, pose
estimate and clicked point), with the topic's type, encoded as CDR or JSON. Anything else is refused
with a warning naming the topic, in the log and to that client as a status message; a message that does
not decode is dropped the same way. The log has at most one line per kind of refusal every WARN_EVERY_S (a client
may send thousands), the client hears of each. Only clients whose browser page comes from an allowed origin
(``allowed_origins``: the Foxglove app and this robot's viewer by default; no Origin at all is a
non-browser client) and that address this server by its own name get past the handshake
(ros/tools/foxglove_server.py). The server calls back from a thread of its own: the callbacks only queue what
happened and trigger a guard condition, and the node acts on it in its executor, so lockstep keeps its order.
"""

from __future__ import annotations

import queue
import sys
from dataclasses import dataclass, field

from geometry_msgs.msg import PointStamped, PoseStamped, PoseWithCovarianceStamped
from rclpy.clock import Clock, ClockType
from rclpy.qos import DurabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.subscription import Subscription

from simplebot_navigation.parameters.spec import Param
from simplebot_navigation.log_throttle import Throttle
from simplebot_navigation.ros.tools.foxglove_server import STATUS_WARNING, FoxgloveServer
from simplebot_navigation.ros.tools.message_json import message_from_json
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import declare_specs, take_live_changes
from simplebot_navigation.ros.tools.raw_topics import RawTopic, TopicDiscovery, publisher_qos
from simplebot_navigation.web_host import FOXGLOVE_ALLOWED_ORIGINS, MAX_ORIGINS, parse_origins

LABEL = "foxglove_bridge parameter"
PARAMETERS = {
    "host": Param(str, "127.0.0.1", "", "address the WebSocket server listens on (0.0.0.0: every one)", dynamic=False),
    "port": Param(int, 8766, "", "port of the WebSocket server (0: a free one)", low=0, high=65535, dynamic=False),
    "allowed_origins": Param(str, " ".join(FOXGLOVE_ALLOWED_ORIGINS), "",
                             f"browser pages that may connect: at most {MAX_ORIGINS} origins (scheme://host[:port]), "
                             "space-separated (the launch file's foxglove_allowed_origins)"),
}
#: the only topics clients may publish on, with their types
CLIENT_TOPICS = {"/move_base_simple/goal": PoseStamped, "/initialpose": PoseWithCovarianceStamped,
                 "/clicked_point": PointStamped}
DISCOVERY_PERIOD_S = 0.5
TIME_PERIOD_NS = 20_000_000   # announce the clock at most every 20 ms of it
WARN_EVERY_S = 5.0            # per kind of bad client message


@dataclass
class _Channel:
    """A topic served to clients: its Foxglove channel and, while clients subscribe, its ROS subscription."""

    topic: RawTopic
    channel: int
    clients: set[int] = field(default_factory=set)
    subscription: Subscription | None = None
    latched: bool = False


@dataclass(frozen=True)
class _ClientChannel:
    topic: str
    encoding: str       # cdr or json


class FoxgloveBridge(SetUpNode):
    def __init__(self, **kwargs):
        self.server = None
        self._channels: dict[int, _Channel] = {}              # by Foxglove channel id
        super().__init__("foxglove_bridge", **kwargs)

    def _set_up(self) -> None:
        p = declare_specs(self, PARAMETERS, LABEL)
        origins = parse_origins(p["allowed_origins"], f"{LABEL} 'allowed_origins'")
        self._log_throttle = Throttle()
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        self._wake = self.create_guard_condition(self._handle_events)
        self._client_channels: dict[tuple[int, int], _ClientChannel] = {}
        self._client_publishers = {topic: self.create_publisher(cls, topic, 10)
                                   for topic, cls in CLIENT_TOPICS.items()}
        self._time_sent: int | None = None
        self.discovery = TopicDiscovery(self, self._skip)
        try:
            self.server = FoxgloveServer("simplebot_navigation", p["host"], p["port"], self._post, origins, self._warn,
                                         metadata={"ROS_DISTRO": "jazzy"})
        except OSError as err:
            raise OSError(f"foxglove_bridge: {err} (set the 'port' parameter, 0 picks a free one)") from err
        take_live_changes(self, PARAMETERS, LABEL, self._take_parameters)
        self.discover()
        self.create_timer(DISCOVERY_PERIOD_S, self.discover, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f"Foxglove WebSocket server on {self.url}")

    def _take_parameters(self, changes: dict) -> None:
        """Only the allowed origins change while running; the next handshakes are checked against them."""
        self.server.allow_origins(parse_origins(changes["allowed_origins"], f"{LABEL} 'allowed_origins'"))

    def _warn(self, kind, text: str) -> None:
        """A warning in the log, at most one per kind every WARN_EVERY_S (rclpy's own throttle is fixed per call
        site: it raises when one call site asks for different ones)."""
        if self._log_throttle(kind, WARN_EVERY_S):
            self.get_logger().warn(text)

    @property
    def url(self) -> str:
        return f"ws://{self.get_parameter('host').value}:{self.server.port}"

    @property
    def port(self) -> int:
        return self.server.port

    # -- channels ---------------------------------------------------------------------------------
    def discover(self) -> None:
        for topic in self.discovery.poll():
            channel = self.server.add_channel(topic.name, "cdr", topic.type_name, topic.definition, "ros2msg")
            self._channels[channel] = _Channel(topic, channel)

    def _skip(self, topic: str, why: str) -> None:
        self.get_logger().warn(f"not serving {topic} to Foxglove: {why}")

    def _subscribe(self, client: int, channel_id: int) -> None:
        served = self._channels.get(channel_id)
        if served is None:
            return
        served.clients.add(client)
        if served.subscription is not None and not served.latched:
            return
        if served.subscription is not None:
            self.destroy_subscription(served.subscription)  # made anew: the new client gets the latched message
        name = served.topic.name
        qos = publisher_qos(self, name)
        served.latched = qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
        served.subscription = self.create_subscription(served.topic.msg_class, name,
                                                       lambda data, s=served: self._forward(s, data), qos, raw=True)

    def _unsubscribe(self, client: int, channel_id: int) -> None:
        served = self._channels.get(channel_id)
        if served is None:
            return
        served.clients.discard(client)
        if not served.clients and served.subscription is not None:
            self.destroy_subscription(served.subscription)
            served.subscription = None

    def _forward(self, served: _Channel, data: bytes) -> None:
        now = self.get_clock().now().nanoseconds
        if self._time_sent is None or abs(now - self._time_sent) >= TIME_PERIOD_NS:
            self.server.broadcast_time(now)
            self._time_sent = now
        self.server.log(served.channel, data, now)

    # -- what clients publish ---------------------------------------------------------------------
    def _advertise(self, client: int, channel_id: int, topic: str, encoding: str, schema_name: str) -> None:
        msg_class = CLIENT_TOPICS.get(topic)
        if msg_class is None:
            return self._refuse(client, "topic", f"may not publish on {topic!r}: clients publish only on "
                                + ", ".join(CLIENT_TOPICS))
        type_name = _type_name(msg_class)
        if schema_name not in (type_name, type_name.replace("/msg/", "/")):
            return self._refuse(client, "schema", f"advertised {topic} as {schema_name!r}; it takes {type_name}")
        if encoding not in ("cdr", "json"):
            return self._refuse(client, "encoding",
                                f"advertised {topic} in encoding {encoding!r}; it takes cdr or json")
        self._client_channels[(client, channel_id)] = _ClientChannel(topic, encoding)

    def _refuse(self, client: int, kind, why: str) -> None:
        """A refused client request: said to that client, which the app shows, and in the log."""
        self.server.status(client, STATUS_WARNING, why)
        self._warn(kind, f"Foxglove client {client} {why}")

    def _publish(self, client: int, channel_id: int, data: bytes) -> None:
        channel = self._client_channels.get((client, channel_id))
        if channel is None:
            return self._refuse(client, "channel", f"message on channel {channel_id}, which was refused; dropped")
        msg_class = CLIENT_TOPICS[channel.topic]
        try:
            if channel.encoding == "json":
                msg = message_from_json(msg_class, data)
            else:
                msg = deserialize_message(data, msg_class)
        except Exception as err:  # noqa: BLE001 - rclpy raises RMWError, UnicodeDecodeError...: any bad bytes
            return self._refuse(client, ("decode", channel.encoding), f"{channel.encoding} message on {channel.topic} "
                                f"does not decode as {_type_name(msg_class)} ({err}); dropped")
        self._client_publishers[channel.topic].publish(msg)
        self.get_logger().info(f"Foxglove client {client} published on {channel.topic}")

    # -- the server's events, handled in the executor -----------------------------------------------
    def _post(self, event: tuple) -> None:
        self._events.put(event)
        self._wake.trigger()

    def _handle_events(self) -> None:
        while True:
            try:
                kind, client, args = self._events.get_nowait()
            except queue.Empty:
                return
            if kind == "subscribe":
                self._subscribe(client, args)
            elif kind == "unsubscribe":
                self._unsubscribe(client, args)
            elif kind == "advertise":
                self._advertise(client, *args)
            elif kind == "unadvertise":
                self._client_channels.pop((client, args), None)
            else:
                self._publish(client, *args)

    def destroy_node(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None
        super().destroy_node()


def _type_name(msg_class: type) -> str:
    return f"{msg_class.__module__.split('.')[0]}/msg/{msg_class.__name__}"


def main(args=None) -> int:
    return run_node("foxglove_bridge", FoxgloveBridge, args, (ValueError, OSError))


if __name__ == "__main__":
    sys.exit(main())
