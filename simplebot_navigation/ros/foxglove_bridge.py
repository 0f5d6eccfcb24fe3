"""Foxglove bridge: every topic of the run on a Foxglove WebSocket server, and goals back from the app.

Each topic of the graph (found as the MCAP recorder finds them, ros/raw_topics.py) becomes a channel
with message encoding ``cdr`` and its ros2msg schema, so the Foxglove app decodes costmaps, plans,
scans, footprints and TF without configuration. A topic is subscribed in ROS only while some client
subscribes to its channel, raw (no decoding), and each message goes out as received, stamped with
this node's clock (simulated time under ``use_sim_time``), which the server also announces to the
app (the ``time`` capability). A latched topic's subscription is made anew for each client that
subscribes, so that it too gets the last message (those already subscribed get it once more).

Clients may publish, but only on the topics of CLIENT_TOPICS (RViz's and the 3D panel's goal, pose
estimate and clicked point), with the topic's type, encoded as CDR or JSON. Anything else is refused
with a warning naming the topic; a message that does not decode is dropped with a warning that says
why. The server calls back from threads of its own: the callbacks only queue what happened and
trigger a guard condition, and the node acts on it in its executor, so lockstep keeps its order.
"""

from __future__ import annotations

import queue
import sys
from dataclasses import dataclass, field

import foxglove
from foxglove.websocket import Capability
from geometry_msgs.msg import PointStamped, PoseStamped, PoseWithCovarianceStamped
from rclpy.clock import Clock, ClockType
from rclpy.qos import DurabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.subscription import Subscription

from simplebot_navigation.ros.message_json import message_from_json
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import declare_checked
from simplebot_navigation.ros.raw_topics import RawTopic, TopicDiscovery, publisher_qos

PARAMETERS = {"host": "127.0.0.1", "port": 8766}
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
    channel: foxglove.Channel
    clients: set[int] = field(default_factory=set)
    subscription: Subscription | None = None
    latched: bool = False


@dataclass(frozen=True)
class _ClientChannel:
    topic: str
    encoding: str       # cdr or json


class _Listener:
    """The server's callbacks (on its threads): queue the event, wake the node."""

    def __init__(self, post):
        self._post = post

    def on_subscribe(self, client, channel) -> None:
        self._post(("subscribe", client.id, channel.id))

    def on_unsubscribe(self, client, channel) -> None:
        self._post(("unsubscribe", client.id, channel.id))

    def on_client_advertise(self, client, channel) -> None:
        self._post(("advertise", client.id, (channel.id, channel.topic, channel.encoding, channel.schema_name)))

    def on_client_unadvertise(self, client, client_channel_id) -> None:
        self._post(("unadvertise", client.id, client_channel_id))

    def on_message_data(self, client, client_channel_id, data) -> None:
        self._post(("data", client.id, (client_channel_id, data)))


class FoxgloveBridge(SetUpNode):
    def __init__(self, **kwargs):
        self.server = None
        self._channels: dict[int, _Channel] = {}              # by Foxglove channel id
        super().__init__("foxglove_bridge", **kwargs)

    def _set_up(self) -> None:
        p = declare_checked(self, PARAMETERS, label="foxglove_bridge parameter")
        if not 0 <= p["port"] <= 65535:
            raise ValueError(f"foxglove_bridge parameter 'port' must be 0..65535, got {p['port']}")
        self._foxglove = foxglove.Context()
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        self._wake = self.create_guard_condition(self._handle_events)
        self._client_channels: dict[tuple[int, int], _ClientChannel] = {}
        self._client_publishers = {topic: self.create_publisher(cls, topic, 10)
                                   for topic, cls in CLIENT_TOPICS.items()}
        self._time_sent: int | None = None
        self.discovery = TopicDiscovery(self, self._skip)
        try:
            self.server = foxglove.start_server(
                name="simplebot_navigation", host=p["host"], port=p["port"], context=self._foxglove,
                capabilities=[Capability.ClientPublish, Capability.Time], supported_encodings=["cdr", "json"],
                server_listener=_Listener(self._post))
        except RuntimeError as err:
            raise OSError(f"foxglove_bridge cannot listen on {p['host']}:{p['port']}: {err} "
                          "(set the 'port' parameter, 0 picks a free one)") from err
        self.discover()
        self.create_timer(DISCOVERY_PERIOD_S, self.discover, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f"Foxglove WebSocket server on {self.url}")

    @property
    def url(self) -> str:
        return f"ws://{self.get_parameter('host').value}:{self.server.port}"

    @property
    def port(self) -> int:
        return self.server.port

    # -- channels ---------------------------------------------------------------------------------
    def discover(self) -> None:
        for topic in self.discovery.poll():
            schema = foxglove.Schema(name=topic.type_name, encoding="ros2msg", data=topic.definition.encode("utf-8"))
            channel = foxglove.Channel(topic.name, message_encoding="cdr", schema=schema, context=self._foxglove)
            self._channels[channel.id()] = _Channel(topic, channel)

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
        served.channel.log(data, log_time=now)

    # -- what clients publish ---------------------------------------------------------------------
    def _advertise(self, client: int, channel_id: int, topic: str, encoding: str, schema_name: str) -> None:
        msg_class = CLIENT_TOPICS.get(topic)
        if msg_class is None:
            self.get_logger().warn(f"Foxglove client {client} may not publish on {topic}: clients publish only on "
                                   + ", ".join(CLIENT_TOPICS))
            return
        type_name = _type_name(msg_class)
        if schema_name not in (type_name, type_name.replace("/msg/", "/")):
            self.get_logger().warn(f"Foxglove client {client} advertised {topic} as {schema_name!r}; "
                                   f"it takes {type_name}")
            return
        if encoding not in ("cdr", "json"):
            self.get_logger().warn(f"Foxglove client {client} advertised {topic} in encoding {encoding!r}; "
                                   "it takes cdr or json")
            return
        self._client_channels[(client, channel_id)] = _ClientChannel(topic, encoding)

    def _publish(self, client: int, channel_id: int, data: bytes) -> None:
        channel = self._client_channels.get((client, channel_id))
        if channel is None:
            self.get_logger().warn(f"Foxglove client {client}: message on channel {channel_id}, which it has not "
                                   "advertised or which was refused; dropped", throttle_duration_sec=WARN_EVERY_S)
            return
        msg_class = CLIENT_TOPICS[channel.topic]
        try:
            if channel.encoding == "json":
                msg = message_from_json(msg_class, data)
            else:
                msg = deserialize_message(data, msg_class)
        except Exception as err:  # noqa: BLE001 - rclpy raises RMWError, UnicodeDecodeError...: any bad bytes
            self.get_logger().warn(f"Foxglove client {client}: {channel.encoding} message on {channel.topic} "
                                   f"does not decode as {_type_name(msg_class)} ({err}); dropped",
                                   throttle_duration_sec=WARN_EVERY_S)
            return
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
        for served in self._channels.values():
            served.channel.close()
        super().destroy_node()


def _type_name(msg_class: type) -> str:
    return f"{msg_class.__module__.split('.')[0]}/msg/{msg_class.__name__}"


def main(args=None) -> int:
    return run_node("foxglove_bridge", FoxgloveBridge, args, (ValueError, OSError))


if __name__ == "__main__":
    sys.exit(main())
