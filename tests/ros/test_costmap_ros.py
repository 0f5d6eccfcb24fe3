"""Costmap2DROS in-process: the lab's move_base parameters, TF and LaserScans in, OccupancyGrids out.

A fake robot stands at the odom origin between two walls: one 2.02 m ahead (x = 2.02), one behind
(x = -1.52), both 6 m long. The wall positions sit mid-cell in both costmaps, so every expected cell
follows from docs/reference.md §2.1 and §2.6 without rounding luck.
"""

import math
import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PolygonStamped, TransformStamped
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.time import Time
from sensor_msgs.msg import LaserScan

from simplebot_navigation.costmap.cost_values import OCCUPANCY_GRID_TABLE
from simplebot_navigation.launch.loader import load_launch
from simplebot_navigation.ros.costmap import costmap_ros
from simplebot_navigation.ros.costmap.costmap_input import point_cloud_xyz
from simplebot_navigation.ros.costmap.costmap_ros import Costmap2DROS
from simplebot_navigation.ros.tf import Buffer, StaticTransformBroadcaster, TransformBroadcaster, TransformListener

N_BEAMS, HALF_FOV, RANGE_MIN, RANGE_MAX = 683, 2.0944, 0.2, 5.6
LASERS = {"front_laser_link": ((0.35, 0.0, 0.15), 0.0, "/front_laser/front_scan"),
          "back_laser_link": ((-0.35, 0.0, 0.15), math.pi, "/back_laser/back_scan")}
FRONT_X, BACK_X = 2.02, -1.52
WALLS = [((FRONT_X, -3.0), (FRONT_X, 3.0)), ((BACK_X, -3.0), (BACK_X, 3.0))]
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)

# The lab's box footprint 0.9 x 0.6 m padded by 0.03: inscribed radius 0.33 m.
INSCRIBED = 0.3 + 0.03
INFLATION_RADIUS, COST_SCALING = 1.5, 8.0


def grid_value(d_cells: int, resolution: float) -> int:
    """OccupancyGrid value of a cell d_cells from the nearest lethal cell (docs/reference.md §2.1, §2.6)."""
    if d_cells == 0:
        return 100
    if d_cells * resolution <= INSCRIBED:
        return 99
    if d_cells * resolution > INFLATION_RADIUS:
        return 0
    cost = int(252 * math.exp(-COST_SCALING * (d_cells * resolution - INSCRIBED)))
    return 0 if cost == 0 else 1 + (97 * (cost - 1)) // 251


def test_expected_values_match_the_reference_table():
    # 0.35 m: 252 exp(-8 * 0.02) = 214.7 -> 214 -> 83; 0.40 m: 143 -> 55; 0.60 m: 29 -> 11; 1.0 m: 1 -> 1
    assert [grid_value(d, 0.05) for d in (0, 6, 7, 8, 12, 20, 21)] == [100, 99, 83, 55, 11, 1, 0]
    assert [grid_value(d, 0.2) for d in (1, 2, 3, 4, 5, 6)] == [99, 55, 11, 2, 1, 0]


def lab_overrides(**extra) -> list[Parameter]:
    spec = next(n for n in load_launch("navigation").nodes if n.name == "move_base")
    params = dict(spec.parameters, use_sim_time=False, **extra)
    return [Parameter(name, value=value) for name, value in params.items()]


def cast(origin, angles, walls) -> np.ndarray:
    """Range along each beam to the nearest wall segment (inf beyond range_max or when nothing is hit)."""
    ox, oy = origin
    dx, dy = np.cos(angles), np.sin(angles)
    best = np.full(len(angles), np.inf)
    for (ax, ay), (bx, by) in walls:
        ex, ey = bx - ax, by - ay
        denom = dx * ey - dy * ex
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((ax - ox) * ey - (ay - oy) * ex) / denom
            s = ((ax - ox) * dy - (ay - oy) * dx) / denom
        hit = (np.abs(denom) > 1e-12) & (t > 0) & (s >= 0) & (s <= 1)
        best = np.where(hit & (t < best), t, best)
    best[best >= RANGE_MAX] = np.inf
    return best


def transform(parent, child, stamp, x, y, yaw, z=0.0) -> TransformStamped:
    tf = TransformStamped()
    tf.header.frame_id, tf.header.stamp, tf.child_frame_id = parent, stamp, child
    tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z = x, y, z
    tf.transform.rotation.z, tf.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return tf


class GridMirror:
    """What a costmap client (RViz) sees: the last full grid with the updates applied."""

    def __init__(self, node: Node, name: str):
        self.grid = None
        self.info = None
        self.full_count = 0
        self.updates: list[OccupancyGridUpdate] = []
        node.create_subscription(OccupancyGrid, f"/{name}/costmap", self._on_grid, LATCHED)
        node.create_subscription(OccupancyGridUpdate, f"/{name}/costmap_updates", self._on_update, 10)

    def _on_grid(self, msg: OccupancyGrid) -> None:
        self.info = msg.info
        self.grid = np.array(msg.data, dtype=np.int8).reshape(msg.info.height, msg.info.width)
        self.full_count += 1

    def _on_update(self, msg: OccupancyGridUpdate) -> None:
        self.updates.append(msg)
        if self.grid is not None:
            patch = np.array(msg.data, dtype=np.int8).reshape(msg.height, msg.width)
            self.grid[msg.y:msg.y + msg.height, msg.x:msg.x + msg.width] = patch

    def cell(self, x: float, y: float) -> tuple[int, int]:
        o, res = self.info.origin.position, self.info.resolution
        return int((x - o.x) / res), int((y - o.y) / res)


class FakeLab:
    """move_base's node with the lab parameters, a TF listener, and a robot publishing TF and scans at 10 Hz."""

    def __init__(self, context: Context, **extra_params):
        self.node = Node("move_base", context=context, parameter_overrides=lab_overrides(**extra_params),
                         automatically_declare_parameters_from_overrides=True)
        self.buffer = Buffer(node=self.node)
        self.listener = TransformListener(self.buffer, self.node)
        self.robot = Node("fake_robot", context=context)
        StaticTransformBroadcaster(self.robot).send_transform(
            [transform("base_link", frame, Time().to_msg(), xyz[0], xyz[1], yaw, xyz[2])
             for frame, (xyz, yaw, _) in LASERS.items()])
        self.tf_pub = TransformBroadcaster(self.robot)
        self.scan_pubs = {frame: self.robot.create_publisher(LaserScan, topic, qos_profile_sensor_data)
                          for frame, (_, _, topic) in LASERS.items()}
        self.pose = (0.0, 0.0, 0.0)
        self.walls = list(WALLS)
        self.edit_ranges = {}           # frame -> function(ranges) -> ranges
        self.publish_tf = True
        self.publish_scans = True
        self.tf_age = 0.0               # seconds the odom -> base_link stamps lag behind now
        self.header_frames = {frame: frame for frame in LASERS}
        self.robot.create_timer(0.1, self.tick)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.robot)
        self.costmaps: list[Costmap2DROS] = []

    def costmap(self, name: str) -> Costmap2DROS:
        self.costmaps.append(Costmap2DROS(self.node, name, self.buffer))
        return self.costmaps[-1]

    def scan(self, frame: str, stamp) -> LaserScan:
        (lx, ly, _), lyaw, _ = LASERS[frame]
        x, y, yaw = self.pose
        origin = (x + lx * math.cos(yaw) - ly * math.sin(yaw), y + lx * math.sin(yaw) + ly * math.cos(yaw))
        beam = np.linspace(-HALF_FOV, HALF_FOV, N_BEAMS)
        ranges = cast(origin, yaw + lyaw + beam, self.walls)
        if frame in self.edit_ranges:
            ranges = self.edit_ranges[frame](ranges)
        msg = LaserScan()
        msg.header.frame_id, msg.header.stamp = self.header_frames[frame], stamp
        msg.angle_min, msg.angle_max, msg.angle_increment = -HALF_FOV, HALF_FOV, 2 * HALF_FOV / (N_BEAMS - 1)
        msg.range_min, msg.range_max, msg.scan_time = RANGE_MIN, RANGE_MAX, 0.1
        msg.ranges = ranges.astype(np.float32).tolist()
        return msg

    def tick(self) -> None:
        now = self.robot.get_clock().now()
        if self.publish_tf:
            stamp = Time(nanoseconds=now.nanoseconds - int(self.tf_age * 1e9)).to_msg()
            self.tf_pub.send_transform(transform("odom", "base_link", stamp, *self.pose))
        if self.publish_scans:
            for frame, pub in self.scan_pubs.items():
                pub.publish(self.scan(frame, now.to_msg()))

    def spin_until(self, predicate, timeout: float = 5.0, what: str = "condition") -> None:
        end = time.monotonic() + timeout
        while not predicate():
            assert time.monotonic() < end, f"timed out after {timeout} s waiting for {what}"
            self.executor.spin_once(timeout_sec=0.02)

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.02)

    def close(self) -> None:
        for costmap in self.costmaps:
            costmap.destroy()
        self.executor.shutdown()
        self.node.destroy_node()
        self.robot.destroy_node()


@pytest.fixture
def lab(context):
    labs = []

    def make(**extra_params) -> FakeLab:
        labs.append(FakeLab(context, **extra_params))
        return labs[-1]

    yield make
    for item in labs:
        item.close()


def walls_seen(mirror: GridMirror) -> bool:
    if mirror.grid is None:
        return False
    row = mirror.cell(0.0, 0.1)[1]
    return all(mirror.grid[row, mirror.cell(x, 0.1)[0]] == 100 for x in (FRONT_X, BACK_X))


def expected_row(mirror: GridMirror) -> np.ndarray:
    """Every cell of a row near y = 0: the inflation profile of the nearer wall (same row)."""
    res = mirror.info.resolution
    cols = np.arange(mirror.info.width)
    front, back = mirror.cell(FRONT_X, 0.0)[0], mirror.cell(BACK_X, 0.0)[0]
    return np.array([grid_value(min(abs(c - front), abs(c - back)), res) for c in cols])


@pytest.mark.parametrize("name, size, resolution, origin", [
    ("local_costmap", 100, 0.05, (-2.45, -2.45)),      # rolling: robot - (n - 0.5) res / 2, whole cells
    ("global_costmap", 150, 0.2, (-15.0, -15.0)),
])
def test_published_grid_shows_the_walls_with_the_inflation_profile(lab, name, size, resolution, origin):
    fake = lab()
    costmap = fake.costmap(name)
    mirror = GridMirror(fake.robot, name)
    fake.spin_until(lambda: walls_seen(mirror), what=f"both walls on /{name}/costmap")
    info = mirror.info
    assert (info.width, info.height, info.resolution) == (size, size, pytest.approx(resolution))
    assert (info.origin.position.x, info.origin.position.y) == pytest.approx(origin)
    assert mirror.grid.shape == (size, size)
    # Rows within the footprint band (|y| < 0.33) are seen in full: between the walls the beams clear,
    # the footprint covers the lasers' blind spot; the lab's master grid is FREE where nothing was
    # seen (track_unknown_space is set for the obstacle layer only), so inflation continues behind
    # the walls as well.
    expected = expected_row(mirror)
    for y in np.arange(-0.3, 0.3, resolution) + resolution / 2:
        row = mirror.cell(0.0, y)[1]
        np.testing.assert_array_equal(mirror.grid[row], expected, err_msg=f"row at y = {y:.3f}")
    # Lethal cells lie exactly on the wall columns, over the wall's length within the map.
    rows, cols = np.nonzero(mirror.grid == 100)
    front, back = mirror.cell(FRONT_X, 0.0)[0], mirror.cell(BACK_X, 0.0)[0]
    assert set(cols) == {front, back}
    ys = info.origin.position.y + (rows + 0.5) * resolution
    assert np.all(np.abs(ys) < 3.0 + resolution)
    # The published grid is the master grid through the table.
    with costmap.lock:
        np.testing.assert_array_equal(mirror.grid, OCCUPANCY_GRID_TABLE[costmap.costmap.costmap])


def test_tracked_unknown_space_is_published_as_minus_one(lab):
    fake = lab(**{"local_costmap.track_unknown_space": True})
    fake.costmap("local_costmap")
    mirror = GridMirror(fake.robot, "local_costmap")
    fake.spin_until(lambda: walls_seen(mirror), what="both walls")
    res = mirror.info.resolution
    front, back = mirror.cell(FRONT_X, 0.0)[0], mirror.cell(BACK_X, 0.0)[0]
    row = mirror.grid[mirror.cell(0.0, 0.1)[1]]
    cols = np.arange(len(row))
    between = (cols > back) & (cols < front)
    np.testing.assert_array_equal(row[between], expected_row(mirror)[between])
    # Behind the walls only the inscribed band (cost 253) is written over unknown cells.
    behind = np.concatenate([back - cols[cols < back], cols[cols > front] - front])
    values = np.concatenate([row[cols < back], row[cols > front]])
    np.testing.assert_array_equal(values, np.where(behind * res <= INSCRIBED, 99, -1))
    # Free cells along the beams, from the front laser to the wall.
    assert np.all(row[mirror.cell(0.4, 0.1)[0]:mirror.cell(FRONT_X - INFLATION_RADIUS, 0.1)[0]] == 0)


def test_nan_ranges_neither_mark_nor_clear(lab):
    fake = lab()
    costmap = fake.costmap("local_costmap")
    post_a, post_b = ((1.02, 0.52), (1.02, 0.68)), ((1.02, -0.68), (1.02, -0.52))
    fake.walls = WALLS + [post_a, post_b]
    master = costmap.costmap

    def lethal(x, y):
        with costmap.lock:
            cell = master.world_to_map(x, y)
            return master.get_cost(*cell) == 254

    fake.spin_until(lambda: lethal(1.02, 0.6) and lethal(1.02, -0.6), what="both posts marked")
    # Beams towards post A turn NaN, post B goes away: B is cleared and the wall behind it marked,
    # while A, behind NaN beams, is neither cleared nor replaced by the wall behind it.
    beam = np.linspace(-HALF_FOV, HALF_FOV, N_BEAMS)
    toward_a = (beam > math.atan2(0.50, 1.02 - 0.35)) & (beam < math.atan2(0.70, 1.02 - 0.35))

    def nan_towards_a(ranges):
        ranges = ranges.copy()
        ranges[toward_a] = np.nan
        return ranges

    fake.edit_ranges["front_laser_link"] = nan_towards_a
    fake.walls = WALLS + [post_a]
    fake.spin_until(lambda: not lethal(1.02, -0.6) and lethal(FRONT_X, -0.6), what="post B cleared")
    assert lethal(1.02, 0.6)
    # The wall behind post A (y 1.30 .. 1.69 along those beams) stays unmarked.
    assert not any(lethal(FRONT_X, y) for y in np.arange(1.35, 1.65, 0.05))
    with costmap.lock:
        lethal_columns = set(np.nonzero(master.costmap == 254)[1])
    assert lethal_columns == {master.world_to_map(x, 0.0)[0] for x in (1.02, FRONT_X, BACK_X)}
    assert costmap.is_current()


def test_costmap_is_not_current_when_scans_stop(lab, capfd):
    fake = lab()
    costmap = fake.costmap("local_costmap")
    fake.spin_until(lambda: costmap.initialized and costmap.is_current(), what="a current costmap")
    fake.publish_scans = False
    fake.spin_until(lambda: not costmap.is_current(), what="the costmap to go stale")
    assert costmap.stale_sources() == ["obstacles/front_laser", "obstacles/back_laser"]
    fake.spin_for(0.1)
    err = capfd.readouterr().err
    assert "local_costmap: The obstacles/front_laser observation buffer (/front_laser/front_scan) has not " \
           "been updated for" in err
    fake.publish_scans = True
    fake.spin_until(costmap.is_current, what="the costmap to be current again")
    assert costmap.stale_sources() == []


def test_costmap_updates_carry_the_changed_cells(lab):
    fake = lab()
    costmap = fake.costmap("global_costmap")
    mirror = GridMirror(fake.robot, "global_costmap")
    fake.spin_until(lambda: walls_seen(mirror), what="both walls")
    full_grids = mirror.full_count
    post = ((1.02, 0.52), (1.02, 0.68))
    fake.walls = WALLS + [post]
    fake.spin_until(lambda: mirror.grid[mirror.cell(1.02, 0.6)[::-1]] == 100, what="the post in an update")
    assert mirror.full_count == full_grids, "a fixed-size costmap sends updates, not full grids"
    update = mirror.updates[-1]
    assert update.header.frame_id == "odom"
    x, y = mirror.cell(1.02, 0.6)
    assert update.x <= x < update.x + update.width and update.y <= y < update.y + update.height
    assert update.width * update.height < 150 * 150
    with costmap.lock:
        np.testing.assert_array_equal(mirror.grid, OCCUPANCY_GRID_TABLE[costmap.costmap.costmap])
    # A late subscriber first gets the latched (old) grid, then a current full one.
    late = GridMirror(fake.robot, "global_costmap")
    fake.spin_until(lambda: late.full_count >= 2, what="a full grid for the late subscriber")
    assert late.grid[late.cell(1.02, 0.6)[::-1]] == 100


def test_footprint_is_published_padded_and_oriented(lab):
    fake = lab()
    fake.pose = (1.0, 0.5, math.pi / 2)
    costmap = fake.costmap("local_costmap")
    received = []
    fake.robot.create_subscription(PolygonStamped, "/local_costmap/footprint", received.append, 10)
    fake.spin_until(lambda: received, what="/local_costmap/footprint")
    msg = received[-1]
    assert msg.header.frame_id == "odom"
    points = sorted((round(p.x, 6), round(p.y, 6)) for p in msg.polygon.points)
    # (±0.48, ±0.33) turned by 90 degrees and moved to (1.0, 0.5).
    assert points == sorted((round(1.0 - y, 6), round(0.5 + x, 6)) for x in (0.48, -0.48) for y in (0.33, -0.33))
    assert costmap.inscribed_radius == pytest.approx(0.33)
    assert costmap.circumscribed_radius == pytest.approx(math.hypot(0.48, 0.33))


def test_robot_pose_older_than_the_tolerance_is_rejected(lab):
    fake = lab()
    fake.tf_age = 1.0
    costmap = fake.costmap("local_costmap")
    fake.spin_until(lambda: fake.buffer.can_transform("odom", "base_link", Time()), what="TF")
    assert costmap.get_robot_pose() is None
    assert costmap.last_pose_error.startswith("Costmap2DROS transform timeout. Current time: ")
    assert costmap.last_pose_error.endswith(", tolerance: 0.5000")
    fake.tf_age = 0.0
    fake.spin_until(lambda: costmap.get_robot_pose() is not None, what="a fresh pose")
    pose = costmap.get_robot_pose()
    assert (pose.x, pose.y, pose.yaw) == (0.0, 0.0, 0.0)


def test_missing_tf_at_start_up_is_reported_without_blocking(lab, capfd, monkeypatch):
    monkeypatch.setattr(costmap_ros, "TF_WAIT_WARNING_PERIOD_S", 0.3)
    fake = lab()
    fake.publish_tf = False
    costmap = fake.costmap("local_costmap")
    fake.spin_for(0.8)
    assert not costmap.initialized and costmap.get_robot_pose() is None
    assert "does not exist" in costmap.last_pose_error
    assert ("local_costmap: Timed out waiting for transform from base_link to odom to become available before "
            "running costmap, tf error: ") in capfd.readouterr().err
    fake.publish_tf = True
    fake.spin_until(lambda: costmap.initialized, what="the first update once TF arrives")


def test_scan_waits_for_its_transform_and_is_dropped_after_the_tolerance(lab, capfd):
    fake = lab()
    costmap = fake.costmap("local_costmap")
    fake.spin_until(lambda: costmap.initialized, what="the first update")
    fake.publish_scans = False
    fake.spin_for(0.15)
    master = costmap.costmap
    post = ((1.02, 0.52), (1.02, 0.68))
    fake.walls = WALLS + [post]
    pub = fake.robot.create_publisher(LaserScan, "/front_laser/front_scan", qos_profile_sensor_data)

    def lethal_post():
        with costmap.lock:
            return master.get_cost(*master.world_to_map(1.02, 0.6)) == 254

    # A scan stamped ahead of the newest odom transform waits for it, then counts.
    ahead = fake.robot.get_clock().now() + rclpy.duration.Duration(seconds=0.25)
    fake.publish_tf = False
    pub.publish(fake.scan("front_laser_link", ahead.to_msg()))
    fake.spin_for(0.15)
    assert not lethal_post()
    fake.tf_pub.send_transform(transform("odom", "base_link", ahead.to_msg(), *fake.pose))
    fake.spin_until(lambda: costmap.update_map_now() and lethal_post(), what="the waiting scan")
    # One whose transform never comes is dropped after transform_tolerance (0.5 s), with the reason.
    far = fake.robot.get_clock().now() + rclpy.duration.Duration(seconds=30.0)
    pub.publish(fake.scan("front_laser_link", far.to_msg()))
    fake.spin_for(0.8)
    assert costmap.input.waiting() == 0
    err = capfd.readouterr().err
    assert "local_costmap: Message Filter dropping message on /front_laser/front_scan: frame 'front_laser_link'" in err
    assert "extrapolation into the future" in err


def test_parameters_are_declared_with_their_effective_values(lab):
    fake = lab()
    fake.costmap("global_costmap")
    node = fake.node
    # Given by the lab's files (copied into the plugin as costmap_2d does).
    assert node.get_parameter("global_costmap.inflation_layer.inflation_radius").value == 1.5
    assert node.get_parameter("global_costmap.global_frame").value == "/odom"
    # Not given: declared with the ROS 1 defaults.
    assert node.get_parameter("global_costmap.always_send_full_costmap").value is False
    assert node.get_parameter("global_costmap.inflation_layer.inflate_unknown").value is False
    assert node.get_parameter("global_costmap.obstacles.combination_method").value == 1
    assert node.get_parameter("global_costmap.obstacles.front_laser.min_obstacle_height").value == 0.0
    assert node.get_parameter("global_costmap.robot_radius").value == 0.46
    assert not node.has_parameter("local_costmap.always_send_full_costmap")


def test_reset_layers_clears_and_publishes_the_whole_grid(lab):
    fake = lab()
    costmap = fake.costmap("global_costmap")
    mirror = GridMirror(fake.robot, "global_costmap")
    fake.spin_until(lambda: walls_seen(mirror), what="both walls")
    fake.publish_scans = False
    fake.spin_for(0.15)
    costmap.reset_layers()
    costmap.publisher.publish_costmap()
    fake.spin_until(lambda: not (mirror.grid == 100).any(), what="an update without the walls")
    update = mirror.updates[-1]
    assert (update.x, update.y, update.width, update.height) == (0, 0, 150, 150)
    assert not (mirror.grid > 0).any()
    # As in costmap_2d, the sources keep their last observation: the next update marks it again.
    assert costmap.update_map_now()
    costmap.publisher.publish_costmap()
    fake.spin_until(lambda: walls_seen(mirror), what="the walls from the buffered scans")


def test_stop_unsubscribes_and_start_subscribes_again(lab):
    fake = lab()
    costmap = fake.costmap("local_costmap")
    front = fake.scan_pubs["front_laser_link"]
    fake.spin_until(lambda: costmap.initialized and front.get_subscription_count() == 1, what="subscriptions")
    costmap.stop()
    fake.spin_until(lambda: front.get_subscription_count() == 0, what="the scan subscription to go")
    costmap.start()
    fake.spin_until(lambda: front.get_subscription_count() == 1, what="the scan subscription to come back")
    fake.spin_until(lambda: costmap.update_map_now() and costmap.is_current(), what="a current costmap")


def test_both_costmaps_read_a_scan_through_one_subscription(lab):
    fake = lab()
    local, global_ = fake.costmap("local_costmap"), fake.costmap("global_costmap")
    front = fake.scan_pubs["front_laser_link"]

    def marked(costmap) -> bool:
        with costmap.lock:
            master = costmap.costmap
            return master.get_cost(*master.world_to_map(FRONT_X, 0.0)) == 254

    fake.spin_until(lambda: marked(local) and marked(global_), what="the wall in both costmaps")
    assert front.get_subscription_count() == 1
    local.stop()
    with global_.lock:
        global_.reset_layers()
    fake.spin_until(lambda: marked(global_), what="the global costmap fed after the local one stopped")
    assert front.get_subscription_count() == 1
    global_.stop()
    fake.spin_until(lambda: front.get_subscription_count() == 0, what="the shared subscription to go")


def test_static_layer_takes_its_size_from_the_map(lab):
    fake = lab(**{"global_costmap.plugins": ["static_layer", "obstacles", "inflation_layer"],
                  "global_costmap.static_layer.plugin": "costmap_2d::StaticLayer"})
    grid = np.zeros((30, 40), dtype=np.int8)        # 4 x 3 m at 0.1, origin (-2, -1.5)
    grid[:, :4] = -1                                # unknown behind the back wall (x < -1.6)
    grid[23:25, 25:27] = 100                        # a block at x 0.5 .. 0.7, y 0.8 .. 1.0
    msg = OccupancyGrid()
    msg.header.frame_id = "odom"
    msg.info.resolution, msg.info.width, msg.info.height = 0.1, 40, 30
    msg.info.origin.position.x, msg.info.origin.position.y = -2.0, -1.5
    msg.info.origin.orientation.w = 1.0
    msg.data = grid.ravel().tolist()
    fake.robot.create_publisher(OccupancyGrid, "/map", LATCHED).publish(msg)
    fake.costmap("global_costmap")  # the Costmap2DROS under test: subscribes to /map and publishes
    mirror = GridMirror(fake.robot, "global_costmap")
    back = (4, 15)                                  # (x, y) = (-1.52, 0.05) in the map's cells

    def back_wall_seen():
        return mirror.grid is not None and mirror.grid.shape == (30, 40) and mirror.grid[back[::-1]] == 100

    fake.spin_until(back_wall_seen, what="the map-sized costmap with the back wall")
    assert (mirror.info.origin.position.x, mirror.info.origin.position.y) == pytest.approx((-2.0, -1.5))
    assert mirror.grid[23, 25] == 100 and mirror.grid[23, 24] == 99
    assert mirror.grid[23, 23] == grid_value(2, 0.1)
    # Unknown in the map and unseen stays unknown except within the inscribed radius of the wall.
    assert mirror.cell(BACK_X, 0.05) == back
    assert (mirror.grid[:, 0] == -1).all() and (mirror.grid[:, 1:4] == 99).all()


def test_point_cloud_source_marks_through_a_rotated_frame(lab):
    fake = lab(**{"local_costmap.obstacles.observation_sources": "front_laser back_laser camera",
                  "local_costmap.obstacles.camera.data_type": "PointCloud2",
                  "local_costmap.obstacles.camera.topic": "/camera/points"})
    costmap = fake.costmap("local_costmap")
    # Points 1.02 m ahead of the back laser, which looks backwards: x = -0.35 - 1.02 in odom.
    ys = np.arange(-4, 4) * 0.05 + 0.025          # cell centres
    points = np.stack([np.full(len(ys), 1.02), ys, np.zeros(len(ys))], axis=1)
    cloud = cloud_msg(points, "back_laser_link")
    pub = fake.robot.create_publisher(type(cloud), "/camera/points", qos_profile_sensor_data)
    master = costmap.costmap

    def marked():
        with costmap.lock:
            return costmap.initialized and all(master.get_cost(*master.world_to_map(-1.37, -y)) == 254 for y in ys)

    def publish_and_check():
        cloud.header.stamp = fake.robot.get_clock().now().to_msg()
        pub.publish(cloud)
        return marked()

    fake.spin_until(publish_and_check, what="the cloud's points in the costmap")


def cloud_msg(points: np.ndarray, frame: str, dtype="<f4", padding: int = 4):
    """A PointCloud2 with x, y, z at offsets 0, s, 2s and `padding` unused bytes per point."""
    from sensor_msgs.msg import PointCloud2, PointField
    item = np.dtype(dtype).itemsize
    kind = {4: PointField.FLOAT32, 8: PointField.FLOAT64}[item]
    structured = np.zeros(len(points), dtype=np.dtype({"names": list("xyz"), "formats": [dtype] * 3,
                                                       "offsets": [0, item, 2 * item],
                                                       "itemsize": 3 * item + padding}))
    for i, axis in enumerate("xyz"):
        structured[axis] = points[:, i]
    msg = PointCloud2()
    msg.header.frame_id = frame
    msg.height, msg.width = 1, len(points)
    msg.fields = [PointField(name=a, offset=i * item, datatype=kind, count=1) for i, a in enumerate("xyz")]
    msg.is_bigendian = dtype.startswith(">")
    msg.point_step = structured.itemsize
    msg.row_step = msg.point_step * len(points)
    msg.data = structured.tobytes()
    msg.is_dense = True
    return msg


@pytest.mark.parametrize("dtype", ["<f4", ">f8"])
def test_point_cloud_fields_are_read_by_offset_type_and_endianness(dtype):
    points = np.array([[1.0, 2.0, 3.0], [-0.5, 0.25, np.nan]])
    xyz = point_cloud_xyz(cloud_msg(points, "cam", dtype))
    np.testing.assert_array_equal(xyz, points)
    msg = cloud_msg(points, "cam")
    msg.fields = msg.fields[:2]
    with pytest.raises(ValueError, match="PointCloud2 has no 'z' field"):
        point_cloud_xyz(msg)


def test_costmap_package_warnings_reach_the_node_logger(lab, capfd):
    fake = lab()
    fake.pose = (20.0, 0.0, 0.0)            # outside the 30 x 30 m global costmap
    costmap = fake.costmap("global_costmap")
    fake.spin_until(lambda: costmap.initialized, what="the first update")
    fake.spin_for(0.3)
    assert ("[move_base]: global_costmap: The origin for the sensor at (20.35, 0.00) is out of map bounds. "
            "So, the costmap cannot raytrace for it.") in capfd.readouterr().err


def test_configured_sensor_frame_overrides_the_message_frame(lab):
    fake = lab()
    fake.header_frames = {"front_laser_link": "laser_from_another_driver", "back_laser_link": ""}
    costmap = fake.costmap("local_costmap")
    mirror = GridMirror(fake.robot, "local_costmap")
    fake.spin_until(lambda: walls_seen(mirror), what="both walls, located through the configured sensor_frame")
    assert costmap.is_current()
