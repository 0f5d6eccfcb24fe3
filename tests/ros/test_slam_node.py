"""The slam node over real topics, in one process: a fake robot publishes TF and both lidars' scans of a 6 x 4 m room
with a box (ray-cast here) and the simulated time on /clock; the node runs synchronously (each scan in its callback)
with the shipped config/slam/slam.yaml. It maps the room as the robot drives 2 m, publishes /map, /map_metadata,
~/graph and map -> odom, saves the map for map_server and its session for later, and loads a session back. Bad scans,
time going back, files it cannot write or read, a localization start without a map and live parameters each get one
clear line, and the node goes on with its map.

Nothing here waits on the wall clock's speed: time is the test's /clock, and every wait spins until a condition holds,
with a generous timeout."""

from __future__ import annotations

import math
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import TransformStamped
from nav2_msgs.srv import LoadMap, SaveMap
from nav_msgs.msg import MapMetaData, OccupancyGrid
from rcl_interfaces.msg import Log
from rosgraph_msgs.msg import Clock
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from simplebot_navigation.geometry import compose2, inverse2
from simplebot_navigation.maps.map_io import load_map
from simplebot_navigation.paths import package_share
from simplebot_navigation.ros.amcl.amcl_messages import post_dated
from simplebot_navigation.ros.conversions import occupancy_map_from_msg, yaw_of
from simplebot_navigation.ros.executor import LeanExecutor
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.ros.slam.slam_node import SlamNode
from simplebot_navigation.ros.tf import StaticTransformBroadcaster, TransformBroadcaster
from simplebot_navigation.slam import session
from simplebot_navigation.slam.mapper import Mapper
from simplebot_navigation.slam.params import SlamParams
from simplebot_navigation.slam.scan_points import MAX_BEAMS, ScanPoints, scan_points
from simplebot_navigation.testing.lidar_scenes import ray_ranges

pytestmark = pytest.mark.timeout(300)
WAIT_S = 30.0
#: the simulated time of the first scan, and between two
START_NS, STEP_NS = 100 * 10 ** 9, 100_000_000

#: the room (6 x 4 m, centred on the odom origin) and a 0.6 x 0.4 m box, as segments (x0, y0, x1, y1)
ROOM = np.array([[-3.0, -2.0, 3.0, -2.0], [3.0, -2.0, 3.0, 2.0], [3.0, 2.0, -3.0, 2.0], [-3.0, 2.0, -3.0, -2.0]])
BOX = np.array([[1.2, 0.8, 1.8, 0.8], [1.8, 0.8, 1.8, 1.2], [1.8, 1.2, 1.2, 1.2], [1.2, 1.2, 1.2, 0.8]])
WALLS = np.concatenate([ROOM, BOX])
#: the real robot's lidars: 683 beams over +-120 deg, 0.2 to 5.6 m, here 0.4 m ahead and behind the base facing out
BEAMS, ANGLE_MIN, RANGE_MIN, RANGE_MAX = 683, -2.0944, 0.2, 5.6
INCREMENT = -2 * ANGLE_MIN / (BEAMS - 1)
LIDARS = {"front_laser/front_scan": ("front_laser_link", (0.4, 0.0, 0.0)),
          "back_laser/back_scan": ("back_laser_link", (-0.4, 0.0, math.pi))}
FRONT, BACK = LIDARS
ROSOUT_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)


def drive(start=(-1.0, -0.3, 0.0), length=2.0, step=0.1):
    """Poses (x, y, yaw) in odom, every ``step`` metres along x, the heading swaying a little."""
    count = round(length / step)
    return [(start[0] + k * step, start[1], start[2] + 0.1 * math.sin(math.pi * k / count)) for k in range(count + 1)]


def ranges_at(pose, mount, walls=WALLS) -> np.ndarray:
    """One lidar's ranges from a robot at ``pose`` (world = odom), +inf beyond range_max."""
    x, y, yaw = compose2(pose, mount)
    r = ray_ranges(np.array([x, y]), yaw + ANGLE_MIN + INCREMENT * np.arange(BEAMS), np.zeros((0, 3)), walls)
    return np.where(r <= RANGE_MAX, r, np.inf)


def scan_msg(frame: str, stamp_ns: int, ranges, **fields) -> LaserScan:
    """A LaserScan of the lidars' geometry; ``fields`` change it."""
    msg = LaserScan()
    msg.header.frame_id, msg.header.stamp = frame, Time(nanoseconds=stamp_ns).to_msg()
    msg.angle_min, msg.angle_increment = ANGLE_MIN, INCREMENT
    msg.range_min, msg.range_max = RANGE_MIN, RANGE_MAX
    msg.ranges = np.asarray(ranges, dtype=np.float32).tolist()
    for name, value in fields.items():
        setattr(msg, name, value)
    msg.angle_max = msg.angle_min + msg.angle_increment * max(len(msg.ranges) - 1, 0)
    return msg


def transform(parent: str, child: str, stamp_ns: int, pose) -> TransformStamped:
    tf = TransformStamped()
    tf.header.frame_id, tf.header.stamp, tf.child_frame_id = parent, Time(nanoseconds=stamp_ns).to_msg(), child
    tf.transform.translation.x, tf.transform.translation.y = pose[0], pose[1]
    tf.transform.rotation.z, tf.transform.rotation.w = math.sin(pose[2] / 2), math.cos(pose[2] / 2)
    return tf


def wall_distance(points: np.ndarray, walls=WALLS) -> np.ndarray:
    """Each point's distance to the nearest wall segment."""
    a, ab = walls[:, :2], walls[:, 2:] - walls[:, :2]
    ap = points[:, None, :] - a[None]
    t = np.clip((ap * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
    return np.linalg.norm(ap - t[..., None] * ab, axis=-1).min(axis=1)


def shipped_parameters(**extra) -> list[Parameter]:
    """config/slam/slam.yaml, synchronous, on the test's /clock, every scan used and /map after every node."""
    shipped = yaml.safe_load((Path(package_share("simplebot_navigation")) / "config/slam/slam.yaml").read_text())
    values = {**shipped, "use_sim_time": True, "synchronous": True, "minimum_time_interval": 0.0,
              "map_update_interval": 0.001, **extra}
    return [Parameter(name, value=value) for name, value in values.items()]


class Robot(Node):
    """The base and its lidars: static base_link -> lidar frames, odom -> base_link, the scans and /clock on
    demand."""

    def __init__(self, context, topics):
        super().__init__("fake_robot", context=context)
        self.static = StaticTransformBroadcaster(self)
        self.static.send_transform([transform("base_link", LIDARS[t][0], 0, LIDARS[t][1]) for t in topics])
        self.tf = TransformBroadcaster(self)
        self.scans = {t: self.create_publisher(LaserScan, t, qos_profile_sensor_data) for t in topics}
        self.clock = self.create_publisher(Clock, "/clock", 10)

    def send_odom(self, pose, stamp_ns: int) -> None:
        self.tf.send_transform(transform("odom", "base_link", stamp_ns, pose))

    def send_scans(self, pose, stamp_ns: int, walls=WALLS) -> None:
        for topic, pub in self.scans.items():
            frame, mount = LIDARS[topic]
            pub.publish(scan_msg(frame, stamp_ns, ranges_at(pose, mount, walls)))


class Probe(Node):
    """What the rest of the stack sees of slam: its logs, /map, /map_metadata, ~/graph and map -> odom."""

    def __init__(self, context, name="slam_probe"):
        super().__init__(name, context=context)
        self.logs: list[tuple[int, str]] = []
        self.maps: list[OccupancyGrid] = []
        self.metadata: list[MapMetaData] = []
        self.graphs: list[MarkerArray] = []
        self.map_to_odom: dict[int, tuple[float, float, float]] = {}     # stamp (ns) -> (x, y, yaw)
        self.create_subscription(Log, "/rosout", lambda m: m.name == "slam" and self.logs.append((m.level, m.msg)),
                                 ROSOUT_QOS)
        self.create_subscription(OccupancyGrid, "/map", self.maps.append, LATCHED)
        self.create_subscription(MapMetaData, "/map_metadata", self.metadata.append, LATCHED)
        self.create_subscription(MarkerArray, "/slam/graph", self.graphs.append, LATCHED)
        self.create_subscription(TFMessage, "/tf", self._on_tf, 100)

    def _on_tf(self, msg: TFMessage) -> None:
        for t in msg.transforms:
            if (t.header.frame_id, t.child_frame_id) == ("map", "odom"):
                self.map_to_odom[Time.from_msg(t.header.stamp).nanoseconds] = (
                    t.transform.translation.x, t.transform.translation.y, yaw_of(t.transform.rotation))


class Rig:
    """slam, the robot and a probe on one executor."""

    def __init__(self, context, **params):
        self.context = context
        self.executor = LeanExecutor(context=context)
        self.nodes: list[Node] = []
        self.probe = self._add(Probe(context))
        self.slam = self._add(SlamNode(context=context, parameter_overrides=shipped_parameters(**params)))
        self.topics = self.slam.topics
        self.robot = self._add(Robot(context, self.topics))
        self._last_stamp, self.clock_ns = 0, 0
        self.tolerance_ns = round(self.slam.params.transform_tolerance * 1e9)
        assert self.spin_until(self._connected), "slam, the robot and the probe did not find each other"

    def _add(self, node: Node) -> Node:
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def _connected(self) -> bool:
        return (all(pub.get_subscription_count() >= 1 for pub in self.robot.scans.values())
                and self.robot.clock.get_subscription_count() >= 1
                and self.robot.tf._pub.get_subscription_count() >= 2
                and self.slam.tf_broadcaster._pub.get_subscription_count() >= 1
                and self.slam.map_pub.get_subscription_count() >= 1
                and all(self.slam.tf.can_transform("base_link", LIDARS[t][0], Time()) for t in self.topics))

    def close(self) -> None:
        self.executor.shutdown()
        for node in reversed(self.nodes):
            node.destroy_node()

    # -- spinning --------------------------------------------------------------------------------
    def spin_until(self, done, seconds: float = WAIT_S) -> bool:
        deadline = time.monotonic() + seconds
        while not done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return bool(done())

    def spin_for(self, seconds: float) -> None:
        """Let callbacks run a while (for what must NOT happen; nothing is timed)."""
        self.spin_until(lambda: False, seconds)

    def next_stamp(self) -> int:
        self._last_stamp = self._last_stamp + STEP_NS if self._last_stamp else START_NS
        return self._last_stamp

    def set_clock(self, ns: int) -> None:
        """/clock at ns, once slam's clock reads it."""
        self.clock_ns = ns
        self.robot.clock.publish(Clock(clock=Time(nanoseconds=ns).to_msg()))
        assert self.spin_until(lambda: self.slam.get_clock().now().nanoseconds == ns), "slam's clock did not follow"

    # -- the robot ---------------------------------------------------------------------------------
    def send_odom(self, pose, stamp_ns: int) -> None:
        """odom -> base_link at stamp_ns, once slam holds it."""
        self.robot.send_odom(pose, stamp_ns)
        assert self.spin_until(lambda: self.slam.tf.can_transform("odom", "base_link", Time(nanoseconds=stamp_ns))), \
            "slam did not get odom -> base_link"

    def step(self, pose, stamp_ns: int | None = None, walls=WALLS) -> int:
        """The robot at ``pose``: the clock (if behind), its odometry, then its scans; returns once slam sent map ->
        odom for them."""
        stamp_ns = self.next_stamp() if stamp_ns is None else stamp_ns
        if stamp_ns > self.clock_ns:
            self.set_clock(stamp_ns)
        self.send_odom(pose, stamp_ns)
        self.robot.send_scans(pose, stamp_ns, walls)
        assert self.spin_until(lambda: self.used(stamp_ns)), f"no map -> odom at {stamp_ns}: {self.logs()[-5:]}"
        return stamp_ns

    def used(self, stamp_ns: int) -> bool:
        """Whether slam gave the scans at stamp_ns to its mapper and sent map -> odom for them (post-dated by
        transform_tolerance; its timer sends it after the newest scan that came, used or not)."""
        return self.slam._last_used_ns >= stamp_ns and \
            Time.from_msg(post_dated(stamp_ns, self.slam.params.transform_tolerance)).nanoseconds \
            in self.probe.map_to_odom

    # -- what comes out -------------------------------------------------------------------------------
    def logs(self, level: int = 0) -> list[str]:
        return [text for lvl, text in self.probe.logs if lvl >= level]

    def wait_log(self, *parts: str, level: int = 0) -> str:
        """The first log line of slam holding every one of ``parts``."""
        def found():
            return next((line for line in self.logs(level) if all(p in line for p in parts)), None)
        assert self.spin_until(lambda: found() is not None), f"no log with {parts}; got {self.logs()[-8:]}"
        return found()

    def call(self, srv_type, name: str, request):
        client = self.probe.create_client(srv_type, name)
        try:
            assert self.spin_until(client.service_is_ready), f"no {name} service"
            future = client.call_async(request)
            assert self.spin_until(future.done), f"{name} did not answer"
            return future.result()
        finally:
            self.probe.destroy_client(client)

    def nodes_count(self) -> int:
        return len(self.slam.mapper.scans)

    def latched(self):
        """(map, graph) a subscriber that comes now gets: what slam keeps latched."""
        late = self._add(Probe(self.context, f"late_probe_{len(self.nodes)}"))
        assert self.spin_until(lambda: late.maps and late.graphs), "no latched map and graph"
        return late.maps[-1], late.graphs[-1]


@pytest.fixture
def rigs(context):
    made: list[Rig] = []

    def make(**params) -> Rig:
        made.append(Rig(context, **params))
        return made[-1]
    yield make
    for rig in made:
        rig.close()


def mapped(rigs, **params) -> Rig:
    """A rig whose slam has mapped the drive's first 1.2 m (three nodes at least); the robot ends at x = 0.2 m."""
    rig = rigs(**params)
    for pose in drive(length=1.2):
        rig.step(pose)
    assert rig.nodes_count() >= 3
    return rig


def nodes_of(graph: MarkerArray) -> int:
    return len(graph.markers[0].points)


def session_of_room(path: Path) -> Path:
    """A session mapped without ROS along the drive (odometry is the truth, and trusted), as serialize_map leaves it."""
    params = SlamParams.from_params({"use_scan_matching": False})
    mapper = Mapper(params)
    for pose in drive():
        parts = [scan_points(ranges_at(pose, mount), ANGLE_MIN, INCREMENT, RANGE_MIN, RANGE_MAX, mount,
                             params.max_laser_range) for _, mount in LIDARS.values()]
        mapper.add_scan(pose, ScanPoints.merged(parts))
    return session.save(mapper, path)


# -- the happy path -----------------------------------------------------------------------------------------
def test_it_maps_the_room_publishes_map_to_odom_and_saves_and_reloads_the_map_and_the_session(rigs, tmp_path):
    rig = rigs()
    path = drive()
    for pose in path:
        rig.step(pose)
    probe = rig.probe
    n = rig.nodes_count()
    assert n >= 4, f"2 m of driving made {n} nodes"
    # map -> odom: odom is the room's frame and mapping began there, so it stays the identity
    x, y, yaw = probe.map_to_odom[max(probe.map_to_odom)]
    assert math.hypot(x, y) < 0.05 and abs(yaw) < 0.02, (x, y, yaw)
    # /map: the walls where they are, within two cells; nothing occupied away from them
    assert rig.spin_until(lambda: probe.graphs and nodes_of(probe.graphs[-1]) == n and probe.maps and probe.metadata)
    grid = probe.maps[-1]
    assert grid.header.frame_id == "map" and probe.metadata[-1] == grid.info
    occupancy = occupancy_map_from_msg(grid)
    res, (ox, oy, _) = occupancy.resolution, occupancy.origin
    assert res == pytest.approx(0.05)
    rows, cols = np.nonzero(occupancy.data == 100)
    cells = np.column_stack((ox + (cols + 0.5) * res, oy + (rows + 0.5) * res))
    assert len(cells) > 300
    off = wall_distance(cells)
    assert off.max() <= 2 * res, f"{(off > 2 * res).sum()} occupied cells off the walls, up to {off.max():.2f} m"
    samples = np.concatenate([np.linspace(w[:2], w[2:], int(math.dist(w[:2], w[2:]) / 0.05)) for w in
                              np.concatenate([ROOM, BOX[[0, 3]]])])     # the box's top and right hide behind it
    seen = np.linalg.norm(samples[:, None] - cells[None], axis=-1).min(axis=1) <= 2 * res
    assert seen.mean() > 0.9, f"only {seen.mean():.0%} of the walls are in the map"
    assert probe.graphs[-1].markers[0].header.frame_id == "map"
    # save_map: map_server's YAML + PGM, read back as published
    assert rig.call(SaveMap, "/slam/save_map", SaveMap.Request(map_url=str(tmp_path / "room"))).result
    saved = load_map(tmp_path / "room.yaml")
    assert (tmp_path / "room.pgm").is_file()
    assert np.array_equal(saved.data, occupancy.data)
    assert saved.resolution == pytest.approx(res) and np.allclose(saved.origin[:2], (ox, oy))
    # serialize_map, drive on (more nodes), deserialize_map: the saved session with its node count is back
    serialized = rig.call(SaveMap, "/slam/serialize_map", SaveMap.Request(map_url=str(tmp_path / "room")))
    assert serialized.result and (tmp_path / "room.posegraph.npz").is_file()
    for pose in drive(start=path[-1], length=1.0, step=0.25)[1:]:
        rig.step(pose)
    assert rig.nodes_count() > n
    loaded = rig.call(LoadMap, "/slam/deserialize_map", LoadMap.Request(map_url=str(tmp_path / "room")))
    assert loaded.result == LoadMap.Response.RESULT_SUCCESS
    assert rig.nodes_count() == n
    assert loaded.map.info.width > 0 and loaded.map.header.frame_id == "map"
    grid, graph = rig.latched()
    assert nodes_of(graph) == n and grid.info.width == loaded.map.info.width
    # and mapping goes on from the loaded session
    rig.step((path[-1][0] + 0.5, path[-1][1], 0.0))
    assert rig.nodes_count() == n + 1
    assert math.dist(rig.slam.mapper.graph.poses[-1][:2], (path[-1][0] + 0.5, path[-1][1])) < 0.05


def test_a_scan_that_comes_before_its_odometry_waits_for_it(rigs):
    """As tf2's message filter: the odometry at a scan's stamp often comes a little after the scan."""
    rig = mapped(rigs)
    pose, stamp = (0.3, -0.3, 0.0), rig.next_stamp()
    rig.set_clock(stamp)
    rig.robot.send_scans(pose, stamp)
    rig.spin_for(0.2)
    assert not rig.used(stamp)
    rig.send_odom(pose, stamp)
    rig.set_clock(stamp + 100_000_000)         # within transform_timeout (0.2 s)
    assert rig.spin_until(lambda: rig.used(stamp)), rig.logs()[-5:]
    assert not [line for line in rig.logs() if "dropped" in line]


def test_a_scan_whose_odometry_never_comes_is_dropped_naming_the_transform(rigs):
    rig = mapped(rigs)
    n = rig.nodes_count()
    stamp = rig.next_stamp()
    rig.set_clock(stamp)
    rig.robot.send_scans((0.3, -0.3, 0.0), stamp)
    rig.spin_for(0.2)
    rig.set_clock(stamp + 10 ** 9)             # beyond transform_timeout
    line = rig.wait_log("scan dropped: no odom -> base_link transform at its stamp", level=Log.WARN)
    assert "\n" not in line
    assert rig.slam._last_used_ns < stamp
    rig.step((0.4, -0.3, 0.0))
    assert rig.nodes_count() >= n


# -- bad input ---------------------------------------------------------------------------------------------
NAN = float("nan")
#: a bad scan on the front lidar (LaserScan fields changed; "stamp": (sec, nanosec)) -> what its line says
BAD_SCANS = {
    "nan_ranges": ({"ranges": [NAN] * BEAMS}, "none of its 683 ranges is usable"),
    "no_beams": ({"ranges": []}, f"ranges: 1 to {MAX_BEAMS} beams, got shape (0,)"),
    "too_many_beams": ({"ranges": [2.0] * (MAX_BEAMS + 1), "angle_increment": 1e-4},
                       f"ranges: 1 to {MAX_BEAMS} beams, got shape ({MAX_BEAMS + 1},)"),
    "zero_angle_increment": ({"angle_increment": 0.0}, "angle_increment: 0.0 over 683 beams is zero"),
    "nan_angle_increment": ({"angle_increment": NAN}, "angle_increment: must be finite, got nan"),
    "range_max_below_range_min": ({"range_min": 3.0, "range_max": 1.0}, "need 0 <= range_min < range_max"),
    "negative_stamp": ({"stamp": (-5, 0)}, "stamp -5.000 s is negative"),
    "stamp_far_ahead": ({"stamp": (10 ** 9, 0)}, "s ahead of the clock"),
}


@pytest.mark.parametrize("case", BAD_SCANS, ids=list(BAD_SCANS))
def test_a_bad_scan_is_dropped_with_one_line_and_the_map_stays(rigs, case):
    fields, said = BAD_SCANS[case]
    rig = mapped(rigs)
    mapper, n = rig.slam.mapper, rig.nodes_count()
    pose, stamp = (0.3, -0.3, 0.0), rig.next_stamp()
    rig.set_clock(stamp)
    rig.send_odom(pose, stamp)
    fields = dict(fields)
    bad_stamp = fields.pop("stamp", None)
    ranges = fields.pop("ranges", ranges_at(pose, LIDARS[FRONT][1]))
    msg = scan_msg(LIDARS[FRONT][0], stamp, ranges, **fields)
    if bad_stamp is not None:
        msg.header.stamp.sec, msg.header.stamp.nanosec = bad_stamp
    rig.robot.scans[FRONT].publish(msg)
    line = rig.wait_log(f"{FRONT}: scan dropped:", said, level=Log.WARN)
    assert "\n" not in line and len(line) < 300, line
    rig.spin_for(0.1)
    assert rig.slam.mapper is mapper and rig.nodes_count() == n
    _, graph = rig.latched()
    assert nodes_of(graph) == n
    rig.step((0.4, -0.3, 0.0))                     # alive, mapping on
    assert rig.slam.mapper is mapper


def test_scans_with_some_nan_ranges_are_used(rigs):
    rig = mapped(rigs)
    pose, stamp = (0.3, -0.3, 0.0), rig.next_stamp()
    rig.set_clock(stamp)
    rig.send_odom(pose, stamp)
    for topic, pub in rig.robot.scans.items():
        ranges = ranges_at(pose, LIDARS[topic][1])
        ranges[::3] = NAN
        pub.publish(scan_msg(LIDARS[topic][0], stamp, ranges))
    assert rig.spin_until(lambda: rig.used(stamp))
    assert not [line for line in rig.logs() if "dropped" in line]


def test_scans_of_one_moment_beyond_the_beam_bound_together_are_dropped_and_the_node_goes_on(rigs):
    """Each lidar's scan is within MAX_BEAMS, both together are not: the merged scan cannot be built."""
    rig = mapped(rigs)
    n = rig.nodes_count()
    pose, stamp = (0.3, -0.3, 0.0), rig.next_stamp()
    rig.set_clock(stamp)
    rig.send_odom(pose, stamp)
    beams = MAX_BEAMS * 3 // 4
    for topic, pub in rig.robot.scans.items():
        pub.publish(scan_msg(LIDARS[topic][0], stamp, [2.0] * beams, angle_increment=4.0 / beams))
    line = rig.wait_log("scan dropped:", f"more than the {MAX_BEAMS}", level=Log.WARN)
    assert "\n" not in line
    rig.step((0.4, -0.3, 0.0))
    assert rig.nodes_count() >= n


def test_time_going_back_clears_the_transforms_and_mapping_goes_on_from_the_last_pose(rigs):
    rig = mapped(rigs)
    n, end = rig.nodes_count(), (0.2, -0.3, 0.0)
    newest = rig._last_stamp
    assert rig.slam.tf.can_transform("odom", "base_link", Time(nanoseconds=newest))
    back = newest - 5 * 10 ** 9
    rig.robot.send_scans(end, back)
    line = rig.wait_log("time went back", level=Log.WARN)
    assert "\n" not in line and (FRONT in line or BACK in line)
    assert not rig.slam.tf.can_transform("odom", "base_link", Time(nanoseconds=newest))     # cleared
    assert rig.nodes_count() == n
    _, graph = rig.latched()
    assert nodes_of(graph) == n
    # odometry goes on from where it was, on the stamps' new timeline
    rig._last_stamp = back
    for pose in drive(start=end, length=1.0, step=0.25)[1:]:
        rig.step(pose)
    assert rig.nodes_count() > n
    mapper = rig.slam.mapper
    for i in range(n, rig.nodes_count()):         # where odometry says (odom is the room's frame)
        assert math.dist(mapper.graph.poses[i][:2], mapper.odometry[i][:2]) < 0.05, i
    assert math.dist(mapper.odometry[n][:2], (end[0] + 0.25, end[1])) < 1e-6
    x, y, _ = rig.probe.map_to_odom[max(rig.probe.map_to_odom)]
    assert math.hypot(x, y) < 0.05


def test_files_it_cannot_write_or_read_are_refused_with_one_line_and_the_map_stays(rigs, tmp_path):
    rig = mapped(rigs)
    mapper, n = rig.slam.mapper, rig.nodes_count()
    for service in ("save_map", "serialize_map"):
        answer = rig.call(SaveMap, f"/slam/{service}", SaveMap.Request(map_url="/proc/x/y"))
        assert not answer.result
        line = rig.wait_log(f"{service}: /proc/x/y", level=Log.ERROR)
        assert "\n" not in line
    good = tmp_path / "good"
    assert rig.call(SaveMap, "/slam/serialize_map", SaveMap.Request(map_url=str(good))).result
    whole = session.session_path(good).read_bytes()
    (tmp_path / "garbage.posegraph.npz").write_bytes(b"this is no zip file\n" * 50)
    (tmp_path / "truncated.posegraph.npz").write_bytes(whole[:len(whole) // 2])
    with zipfile.ZipFile(tmp_path / "empty.posegraph.npz", "w") as empty:
        empty.writestr("nothing.npy", b"")
    np.savez(tmp_path / "wrong.posegraph.npz", format=np.array("something else"), version=np.array(7))
    invalid = LoadMap.Response.RESULT_INVALID_MAP_DATA
    cases = {"garbage": invalid, "truncated": invalid, "empty": invalid, "wrong": invalid,
             "missing": LoadMap.Response.RESULT_MAP_DOES_NOT_EXIST}
    for name, result in cases.items():
        answer = rig.call(LoadMap, "/slam/deserialize_map", LoadMap.Request(map_url=str(tmp_path / name)))
        assert answer.result == result, name
        line = rig.wait_log("deserialize_map:", f"{name}.posegraph.npz", "the current map stays", level=Log.ERROR)
        assert "\n" not in line
        assert rig.slam.mapper is mapper and rig.nodes_count() == n
    _, graph = rig.latched()
    assert nodes_of(graph) == n
    assert rig.call(SaveMap, "/slam/save_map", SaveMap.Request(map_url=str(tmp_path / "after"))).result
    rig.step((0.3, -0.3, 0.0))


# -- localization ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("map_file", ["", "missing"])
def test_a_localization_start_without_a_map_waits_for_deserialize_map_then_localizes(rigs, tmp_path, map_file):
    good = session_of_room(tmp_path / "room")
    extra = {"map_file_name": str(tmp_path / map_file)} if map_file else {}
    rig = rigs(mode="localization", **extra)
    if map_file:
        line = rig.wait_log("map_file_name:", "no such file", "no map to localize on", level=Log.ERROR)
    else:
        line = rig.wait_log("localization needs a map", level=Log.WARN)
    assert "\n" not in line and rig.slam.mapper is None
    # the odometry frame is off the map's by centimetres and a degree or two: localization finds the offset
    truth = (0.12, -0.08, 0.03)
    path = drive(length=1.0, step=0.5)
    odom = [compose2(inverse2(truth), pose) for pose in path]
    stamp = rig.next_stamp()
    rig.set_clock(stamp)
    rig.send_odom(odom[0], stamp)
    rig.robot.send_scans(path[0], stamp)
    rig.wait_log("no map to localize on: set map_file_name or call deserialize_map", level=Log.WARN)
    rig.spin_for(0.1)
    assert not rig.probe.map_to_odom
    loaded = rig.call(LoadMap, "/slam/deserialize_map", LoadMap.Request(map_url=str(good)))
    assert loaded.result == LoadMap.Response.RESULT_SUCCESS
    assert rig.spin_until(lambda: rig.probe.maps) and rig.probe.maps[-1].info.width == loaded.map.info.width
    n = rig.nodes_count()
    for pose, odom_pose in zip(path, odom):
        stamp = rig.next_stamp()
        rig.set_clock(stamp)
        rig.send_odom(odom_pose, stamp)
        rig.robot.send_scans(pose, stamp)
        assert rig.spin_until(lambda: rig.used(stamp)), rig.logs()[-5:]
    x, y, yaw = rig.probe.map_to_odom[max(rig.probe.map_to_odom)]
    assert math.hypot(x - truth[0], y - truth[1]) < 0.05 and abs(yaw - truth[2]) < 0.01, (x, y, yaw)   # a cell
    assert rig.nodes_count() == n                  # localization does not extend the map


# -- live parameters ---------------------------------------------------------------------------------------
def test_live_parameters_restart_only_and_out_of_range_ones_are_refused_with_a_reason(rigs):
    rig = mapped(rigs)
    slam = rig.slam
    refused = slam.set_parameters([Parameter("resolution", value=0.1)])[0]
    assert not refused.successful and "resolution" in refused.reason and "restart" in refused.reason
    refused = slam.set_parameters([Parameter("minimum_travel_distance", value=-1.0)])[0]
    assert not refused.successful and "minimum_travel_distance" in refused.reason, refused.reason
    assert slam.params.resolution == 0.05 and slam.params.minimum_travel_distance == 0.5
    assert slam.set_parameters([Parameter("minimum_travel_distance", value=0.2)])[0].successful
    assert slam.params.minimum_travel_distance == 0.2 and slam.mapper.params.minimum_travel_distance == 0.2
    n = rig.nodes_count()
    for pose in drive(start=(0.2, -0.3, 0.0), length=0.75, step=0.25)[1:]:     # a node every 0.25 m now
        rig.step(pose)
    assert rig.nodes_count() == n + 3
