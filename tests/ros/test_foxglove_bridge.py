"""The Foxglove bridge in a lockstep run of the empty world, seen from a Foxglove WebSocket client:
channels with ros2msg schemas, TF that decodes, goals published from the app that move_base drives to,
and hostile clients refused without harm."""

import json
import socket
import struct
import subprocess
import sys
import time
from collections import defaultdict
from contextlib import ExitStack
from pathlib import Path

import pytest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message, serialize_message
from tf2_msgs.msg import TFMessage
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from simplebot_navigation.launch.loader import load_launch
from simplebot_navigation.ros.tools.foxglove_bridge import CLIENT_TOPICS, FoxgloveBridge
from simplebot_navigation.ros.tools.message_json import message_from_json
from simplebot_navigation.ros.tools.raw_topics import message_definition
from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.web_host import FOXGLOVE_ALLOWED_ORIGINS

LAYOUT = Path(__file__).resolve().parents[2] / "config" / "simplebot.foxglove.json"
SUBPROTOCOL = "foxglove.sdk.v1"   # one of the two the Foxglove app offers
GOAL = "/move_base_simple/goal"
SHOWN = {"/tf": "tf2_msgs/msg/TFMessage", "/tf_static": "tf2_msgs/msg/TFMessage",
         "/global_costmap/costmap": "nav_msgs/msg/OccupancyGrid",
         "/local_costmap/costmap": "nav_msgs/msg/OccupancyGrid",
         "/move_base/GlobalPlanner/plan": "nav_msgs/msg/Path", "/front_laser/front_scan": "sensor_msgs/msg/LaserScan",
         "/local_costmap/footprint": "geometry_msgs/msg/PolygonStamped", GOAL: "geometry_msgs/msg/PoseStamped"}


class FoxgloveClient:
    """The app's side of the Foxglove WebSocket protocol, as much as the tests need. Lockstep time advances
    only while the client waits (pump), so the bridge's executor handles what the client sent."""

    def __init__(self, session: NavigationSession, url: str, subprotocol: str = SUBPROTOCOL):
        self.session = session
        self._stack = ExitStack()
        self.ws = self._stack.enter_context(connect(url, subprotocols=[subprotocol], open_timeout=10))
        self.info = json.loads(self.ws.recv(timeout=10))
        self.channels: dict[str, dict] = {}
        self.messages: dict[int, list[tuple[int, bytes]]] = defaultdict(list)  # subscription -> (log time, data)
        self.times: list[int] = []
        self.statuses: list[str] = []
        self.errors: list[str] = []      # the statuses of level error
        self._next_id = 0
        self.pump(lambda: GOAL in self.channels, "the server's channels")

    def _read(self) -> None:
        while True:
            try:
                frame = self.ws.recv(timeout=0)
            except TimeoutError:
                return
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise":
                    self.channels.update({c["topic"]: c for c in message["channels"]})
                elif message["op"] == "status":
                    self.statuses.append(message["message"])
                    if message["level"] == 2:
                        self.errors.append(message["message"])
            elif frame[0] == 1:   # message data: subscription id, log time, payload
                subscription, log_time = struct.unpack_from("<IQ", frame, 1)
                self.messages[subscription].append((log_time, frame[13:]))
            elif frame[0] == 2:   # time
                self.times.append(struct.unpack_from("<Q", frame, 1)[0])

    def pump(self, done, what: str, wall_s: float = 20.0) -> None:
        deadline = time.monotonic() + wall_s
        self._read()
        while not done():
            assert time.monotonic() < deadline, f"timed out waiting for {what}"
            self.session.run_for(0.05)
            self._read()

    def _id(self) -> int:
        self._next_id += 1
        return self._next_id

    def subscribe(self, topic: str) -> int:
        subscription = self._id()
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": subscription, "channelId": self.channels[topic]["id"]}]}))
        return subscription

    def unsubscribe(self, subscription: int) -> None:
        self.ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": [subscription]}))

    def advertise(self, topic: str, encoding: str, schema_name: str) -> int:
        channel = self._id()
        self.ws.send(json.dumps({"op": "advertise", "channels": [
            {"id": channel, "topic": topic, "encoding": encoding, "schemaName": schema_name}]}))
        return channel

    def publish(self, channel: int, payload: bytes) -> None:
        self.ws.send(b"\x01" + struct.pack("<I", channel) + payload)

    def close(self) -> None:
        self._stack.close()


@pytest.fixture(scope="module")
def session():
    with NavigationSession("empty", foxglove_port=0) as run:
        run.wait_ready()
        yield run


@pytest.fixture(scope="module")
def bridge(session):
    return next(n for n in session.nodes if isinstance(n, FoxgloveBridge))


@pytest.fixture
def client(session, bridge):
    app = FoxgloveClient(session, bridge.url)
    yield app
    app.close()


def bridge_subscriptions(bridge) -> set[str]:
    return {name for name, _ in bridge.get_subscriber_names_and_types_by_node(bridge.get_name(), "/")}


def goal_message(x: float, y: float) -> PoseStamped:
    goal = PoseStamped()
    goal.header.frame_id = "odom"
    goal.pose.position.x, goal.pose.position.y = x, y
    goal.pose.orientation.w = 1.0
    return goal


def drive_to(session, x: float, y: float) -> None:
    """Run until move_base reports the simple goal at (x, y) reached; the robot must be there."""
    def reached():
        status = session.client.status
        return bool(status and status.status_list) and status.status_list[-1].status == GoalStatus.SUCCEEDED \
            and abs(session.pose().x - x) < 0.25 and abs(session.pose().y - y) < 0.25
    assert session.run_for(30.0, reached, wall_timeout_s=40.0), \
        f"robot at {session.pose()} did not reach ({x}, {y}); status {session.client.status}"


def test_every_topic_is_a_cdr_channel_with_its_ros2msg_schema(client):
    assert client.info["capabilities"] == ["clientPublish", "time"]
    assert client.info["supportedEncodings"] == ["cdr", "json"]
    for topic, type_name in SHOWN.items():
        channel = client.channels[topic]
        assert (channel["encoding"], channel["schemaEncoding"], channel["schemaName"]) == ("cdr", "ros2msg", type_name)
        assert channel["schema"] == message_definition(type_name)
    assert not any(part.startswith("_") for topic in client.channels for part in topic.split("/"))


def test_tf_arrives_as_cdr_stamped_with_sim_time_and_only_while_subscribed(session, bridge, client):
    assert "/tf" not in bridge_subscriptions(bridge)   # nobody looks: no ROS subscription
    tf, static = client.subscribe("/tf"), client.subscribe("/tf_static")
    client.pump(lambda: client.messages[tf] and client.messages[static], "/tf and /tf_static")
    log_time, data = client.messages[tf][-1]
    moving = deserialize_message(data, TFMessage)
    assert ("odom", "base_link") in {(t.header.frame_id, t.child_frame_id) for t in moving.transforms}
    stamp = moving.transforms[0].header.stamp
    assert abs(log_time - (stamp.sec * 10**9 + stamp.nanosec)) < 50_000_000   # sim time, as the header
    assert client.times and abs(client.times[-1] - log_time) < 50_000_000     # the app's clock: sim time
    fixed = deserialize_message(client.messages[static][0][1], TFMessage)
    assert ("base_link", "front_laser_link") in {(t.header.frame_id, t.child_frame_id) for t in fixed.transforms}
    assert {"/tf", "/tf_static"} <= bridge_subscriptions(bridge)
    client.unsubscribe(tf)
    client.pump(lambda: "/tf" not in bridge_subscriptions(bridge), "the bridge to drop its /tf subscription")


def test_a_second_app_also_gets_the_latched_transforms(session, bridge, client):
    first = client.subscribe("/tf_static")
    client.pump(lambda: client.messages[first], "/tf_static for the first client")
    second = FoxgloveClient(session, bridge.url)
    try:
        late = second.subscribe("/tf_static")
        second.pump(lambda: second.messages[late], "/tf_static for the second client")
        fixed = deserialize_message(second.messages[late][0][1], TFMessage)
        assert len(fixed.transforms) == len(deserialize_message(client.messages[first][0][1], TFMessage).transforms)
    finally:
        second.close()


def test_goals_published_from_the_app_are_driven_to(session, client):
    # The app publishes CDR when the server lists it first, and JSON (the Publish panel's text) otherwise.
    start = session.pose()
    cdr = client.advertise(GOAL, "cdr", "geometry_msgs/msg/PoseStamped")
    client.publish(cdr, serialize_message(goal_message(start.x + 1.5, start.y)))
    drive_to(session, start.x + 1.5, start.y)
    as_json = client.advertise(GOAL, "json", "geometry_msgs/PoseStamped")
    client.publish(as_json, json.dumps({"header": {"stamp": {"sec": 0, "nsec": 0}, "frame_id": "odom"},
                                        "pose": {"position": {"x": start.x + 2.5, "y": start.y},
                                                 "orientation": {"w": 1.0}}}).encode())
    drive_to(session, start.x + 2.5, start.y)


def test_hostile_clients_are_refused_with_a_warning_and_the_bridge_carries_on(session, bridge, client, monkeypatch):
    warnings: list[str] = []
    logger = bridge.get_logger()
    monkeypatch.setattr(logger, "warn", lambda message, **kwargs: warnings.append(message))
    goals: list[PoseStamped] = []
    session.client.create_subscription(PoseStamped, GOAL, goals.append, 10)

    def warned(*words):
        client.pump(lambda: any(all(w in m for w in words) for m in warnings), f"a warning with {words}")

    client.advertise("/simplebot_controller/cmd_vel", "json", "geometry_msgs/msg/Twist")
    warned("may not publish on '/simplebot_controller/cmd_vel'")
    client.advertise(GOAL, "json", "geometry_msgs/msg/Twist")
    warned(GOAL, "'geometry_msgs/msg/Twist'", "it takes geometry_msgs/msg/PoseStamped")
    client.advertise(GOAL, "protobuf", "geometry_msgs/msg/PoseStamped")
    warned(GOAL, "encoding 'protobuf'")
    cdr = client.advertise(GOAL, "cdr", "geometry_msgs/msg/PoseStamped")
    client.publish(cdr, b"\x00\x01\x00\x00" + b"\xff" * 40)
    warned("cdr message on /move_base_simple/goal does not decode")
    as_json = client.advertise(GOAL, "json", "geometry_msgs/msg/PoseStamped")
    client.publish(as_json, b'{"pose": {"position": {"x": "far"}}}')
    warned("json message on /move_base_simple/goal", "pose.position.x must be of type double, got str")
    client.publish(999, b"{}")
    client.pump(lambda: any("channel 999" in m for m in client.statuses), "a status about channel 999")
    assert not goals   # nothing reached ROS
    told = "\n".join(client.statuses)    # each refusal also went to the client that made it, which the app shows
    assert "may not publish on '/simplebot_controller/cmd_vel'" in told and "encoding 'protobuf'" in told
    assert "cdr message on /move_base_simple/goal does not decode" in told
    # the next good goal still goes through
    client.publish(cdr, serialize_message(goal_message(0.0, 0.0)))
    client.pump(lambda: goals, "the good goal on /move_base_simple/goal")
    assert (goals[0].pose.position.x, goals[0].header.frame_id) == (0.0, "odom")


@pytest.mark.parametrize("first, second", [
    (("advertise", "/simplebot_controller/cmd_vel", "geometry_msgs/msg/Twist"), ("publish", b'{"linear":{"x":0.3}}')),
    (("advertise", GOAL, "geometry_msgs/msg/PoseStamped"), ("publish", b"not json")),
], ids=["cmd_vel then its message", "a message that does not decode"])
def test_refusals_one_after_the_other_leave_the_bridge_running(session, bridge, first, second):
    """Issue 43, probe 1: two refusals of different kinds in a row, with the node's real logger (rclpy refuses a
    call site whose throttle changes between calls, which ended the bridge)."""
    goals: list[PoseStamped] = []
    subscription = session.client.create_subscription(PoseStamped, GOAL, goals.append, 10)
    app = FoxgloveClient(session, bridge.url, "foxglove.websocket.v1")
    try:
        channel = app.advertise(first[1], "json", first[2])
        app.publish(channel, second[1])
        wrong = app.advertise(GOAL, "json", "geometry_msgs/msg/Twist")   # then a refusal of a third kind
        app.publish(wrong, b"{}")
        app.pump(lambda: any(f"message on channel {wrong}, which was refused" in m for m in app.statuses),
                 "the last refusal told to the client")
        assert len(app.statuses) == (4 if first[1] != GOAL else 3), app.statuses    # each refusal told
        good = app.advertise(GOAL, "cdr", "geometry_msgs/msg/PoseStamped")
        app.publish(good, serialize_message(goal_message(0.0, 0.0)))
        app.pump(lambda: goals, "the next good goal, which only a running bridge passes on")
    finally:
        app.close()
        session.client.destroy_subscription(subscription)


#: subscription and channel ids that are not uint32, as JSON text
NOT_UINT32 = ["-1", str(2**33), "1e400", "1.5", "true", '"7"', "null"]


def test_ids_outside_uint32_are_refused_and_the_other_clients_keep_receiving(session, bridge, monkeypatch):
    """Issue 43, probe 5: a client that subscribes with id -1 or 2**33 made the fan-out raise for it on every
    message, and the clients after it received nothing; 1e400 closed its connection."""
    warnings: list[str] = []
    monkeypatch.setattr(bridge.get_logger(), "warn", lambda message, **kwargs: warnings.append(message))
    hostile = FoxgloveClient(session, bridge.url)     # first in the server's list of clients
    other = FoxgloveClient(session, bridge.url)
    try:
        tf = hostile.channels["/tf"]["id"]
        for bad in ("-1", str(2**33)):    # the probe: every client after this one stopped receiving
            hostile.ws.send(f'{{"op":"subscribe","subscriptions":[{{"id":{bad},"channelId":{tf}}}]}}')
        watched = other.subscribe("/tf")
        other.pump(lambda: len(other.messages[watched]) >= 10, "/tf for the other client")
        requests = [f'{{"op":"subscribe","subscriptions":[{{"id":{bad},"channelId":{tf}}}]}}' for bad in NOT_UINT32]
        requests += [f'{{"op":"subscribe","subscriptions":[{{"id":1,"channelId":{bad}}}]}}' for bad in NOT_UINT32]
        requests += [f'{{"op":"unsubscribe","subscriptionIds":[{bad}]}}' for bad in NOT_UINT32]
        requests += [f'{{"op":"unadvertise","channelIds":[{bad}]}}' for bad in NOT_UINT32]
        requests += [f'{{"op":"advertise","channels":[{{"id":{bad},"topic":"{GOAL}","encoding":"json",'
                     f'"schemaName":"geometry_msgs/msg/PoseStamped"}}]}}' for bad in NOT_UINT32]
        for request in requests:
            hostile.ws.send(request)
        hostile.pump(lambda: len(hostile.errors) >= len(requests) + 2, "an error status for each bad id")
        assert all("uint32" in message for message in hostile.errors), hostile.errors
        assert any("subscription id -1 is not a uint32" in message for message in hostile.errors), hostile.errors
        assert any(f"channel id {2**33} is not a uint32" in message for message in hostile.errors), hostile.errors
        assert 1 <= sum("uint32" in w for w in warnings) <= 3, warnings   # a line in the log, not one per request
        count = len(other.messages[watched])
        other.pump(lambda: len(other.messages[watched]) >= count + 10, "more /tf for the other client")
        mine = hostile.subscribe("/tf")     # the hostile client's connection is still open and served
        hostile.pump(lambda: hostile.messages[mine], "/tf for the refused client's good subscription")
        assert not hostile.messages.keys() - {mine}
    finally:
        hostile.close()
        other.close()


def test_the_layout_shows_topics_of_the_run_and_publishes_where_the_bridge_listens(client):
    layout = json.loads(LAYOUT.read_text())
    panels = layout["configById"]

    def placed(node):
        return {node} if isinstance(node, str) else placed(node["first"]) | placed(node["second"])
    assert placed(layout["layout"]) == set(panels)
    scene = panels["3D!simplebot"]
    assert (scene["fixedFrame"], scene["followTf"]) == ("odom", "base_link")
    shown = {topic for topic, settings in scene["topics"].items() if settings["visible"]}
    # The simulator advertises its moving obstacles only in a world that has some (the lab has none).
    assert shown - {"/sim/moving_obstacles"} <= set(client.channels)
    assert {"/sim/moving_obstacles", "/move_base/obstacle_tracks/markers"} <= shown
    assert set(SHOWN) - {"/tf", "/tf_static", GOAL} | {"/back_laser/back_scan", "/robot_description"} <= shown
    assert {"/global_costmap/costmap", "/local_costmap/costmap"} == {
        topic for topic, settings in scene["topics"].items() if settings.get("colorMode") == "costmap"}
    tools = scene["publish"]
    assert {tools["poseTopic"], tools["pointTopic"], tools["poseEstimateTopic"]} == set(CLIENT_TOPICS)
    publish = panels["Publish!goal"]
    assert (publish["topicName"], publish["datatype"]) == (GOAL, client.channels[GOAL]["schemaName"])
    goal = message_from_json(PoseStamped, publish["value"].encode())
    assert (goal.header.frame_id, goal.pose.orientation.w) == ("odom", 1.0)
    plotted = {series["value"].split(".")[0] for series in panels["Plot!cmd_vel"]["paths"]}
    assert plotted == {"/simplebot_controller/cmd_vel"} and plotted <= set(client.channels)


def test_a_client_that_churns_subscriptions_is_held_to_a_budget(client):
    """Each subscription change costs the bridge a ROS subscription made or destroyed, which every node hears about."""
    channel = client.channels["/tf"]["id"]
    for i in range(150):
        client.ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 5000 + i, "channelId": channel}]}))
        client.ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": [5000 + i]}))
    client.pump(lambda: any("ignored: more than 20 subscription or advertisement changes a second" in m
                            for m in client.statuses), "the status about the budget")


@pytest.mark.parametrize("origin", ["https://evil.example", "http://127.0.0.1:9999", "null"])
def test_a_page_of_another_origin_cannot_connect(bridge, origin):
    with pytest.raises(InvalidStatus, match="HTTP 403"):
        connect(bridge.url, subprotocols=[SUBPROTOCOL], origin=origin, open_timeout=10)


@pytest.mark.parametrize("origin", ["https://app.foxglove.dev", "http://localhost:8765", None])
def test_the_app_the_viewer_and_non_browser_clients_can_connect(bridge, origin):
    with connect(bridge.url, subprotocols=[SUBPROTOCOL], origin=origin, open_timeout=10) as ws:
        assert json.loads(ws.recv(timeout=10))["op"] == "serverInfo"


@pytest.mark.parametrize("host", ["evil.example", "robot.attacker.net", "10.0.0.1"])
def test_a_foreign_host_name_is_refused_against_dns_rebinding(bridge, host):
    with pytest.raises(InvalidStatus, match="HTTP 403"):
        connect(f"ws://{host}:{bridge.port}", sock=socket.create_connection(("127.0.0.1", bridge.port)),
                subprotocols=[SUBPROTOCOL], open_timeout=10)


def test_the_launch_file_starts_the_bridge_on_request():
    nodes = {n.name: n for n in load_launch("navigation", {"foxglove": "true", "foxglove_port": "9001"}).nodes}
    assert (nodes["foxglove_bridge"].type, nodes["foxglove_bridge"].parameters["port"]) == ("foxglove_bridge", 9001)
    assert nodes["foxglove_bridge"].parameters["host"] == "127.0.0.1"
    assert "foxglove_bridge" not in {n.name for n in load_launch("navigation", {}).nodes}


def test_a_bad_or_busy_port_is_named(context, bridge):
    with pytest.raises(ValueError, match=r"foxglove_bridge parameter 'port': must be in \[0, 65535\], got 70000"):
        FoxgloveBridge(context=context, parameter_overrides=[Parameter("port", value=70000)])
    with pytest.raises(OSError, match=f"cannot listen on 127.0.0.1:{bridge.port}: .*(?i:address already in use)"):
        FoxgloveBridge(context=context, parameter_overrides=[Parameter("port", value=bridge.port)])


@pytest.mark.parametrize("name, value, said", [
    ("port", 9000, "requires restart"),
    ("host", "0.0.0.0", "requires restart"),
    ("allowed_origins", "https://app.foxglove.dev null", "'null' is not an origin"),
    ("allowed_origins", "javascript:alert(1)", "'javascript:alert(1)' is not an origin"),
    ("allowed_origins", " ".join(["https://a.example"] * 65), "at most 64 origins, got 65"),
    ("allowed_origins", 7, "expected a string, got 7"),
])
def test_live_changes_out_of_bounds_are_refused_with_the_reason(bridge, name, value, said):
    result = bridge.set_parameters([Parameter(name, value=value)])[0]
    assert not result.successful and f"foxglove_bridge parameter '{name}'" in result.reason and said in result.reason
    with connect(bridge.url, subprotocols=[SUBPROTOCOL], origin="https://app.foxglove.dev", open_timeout=10):
        pass   # the origins are those of the start


def test_allowed_origins_change_while_running(bridge):
    try:
        assert bridge.set_parameters([Parameter("allowed_origins", value="http://robot-pc:8765")])[0].successful
        with connect(bridge.url, subprotocols=[SUBPROTOCOL], origin="http://robot-pc:8765", open_timeout=10) as ws:
            assert json.loads(ws.recv(timeout=10))["op"] == "serverInfo"
        with pytest.raises(InvalidStatus, match="HTTP 403"):
            connect(bridge.url, subprotocols=[SUBPROTOCOL], origin="https://app.foxglove.dev", open_timeout=10)
    finally:
        bridge.set_parameters([Parameter("allowed_origins", value=" ".join(FOXGLOVE_ALLOWED_ORIGINS))])


def test_the_node_process_reports_a_bad_parameter_in_one_line():
    result = subprocess.run([sys.executable, "-m", "simplebot_navigation.ros.tools.foxglove_bridge", "--ros-args",
                             "-p", "port:=-1"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr.strip() == "foxglove_bridge: foxglove_bridge parameter 'port': must be in [0, 65535], got -1"
