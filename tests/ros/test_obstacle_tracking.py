"""move_base's obstacle tracking over real topics: a fake robot publishes TF and both lidars' scans of a person
walking past (10 Hz, wall clock); move_base publishes the person on obstacle_tracks with one id and its velocity,
hands it to the local planner through the obstacle feed, clears its marks from the local costmap, and takes other
nodes' obstacles (on TebLocalPlannerROS/obstacles) into the same feed, dropping bad ones."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import rclpy
from builtin_interfaces.msg import Time as TimeMsg
from costmap_converter_msgs.msg import ObstacleArrayMsg, ObstacleMsg
from geometry_msgs.msg import Point32
from nav_msgs.msg import OccupancyGrid
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.launch.loader import load_launch
from simplebot_navigation.perception.tracker import Track
from simplebot_navigation.ros.move_base.obstacle_msgs import obstacle_array_msg
from simplebot_navigation.ros.move_base.move_base_node import MoveBaseNode
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.ros.tf import StaticTransformBroadcaster, TransformBroadcaster
from simplebot_navigation.testing.lidar_scenes import Cylinder, lidars, scans_at, truth_at
from tests.ros.test_costmap_ros import transform

pytestmark = pytest.mark.timeout(120)
TRACKS = "/move_base/obstacle_tracks"
OBSTACLES = "/move_base/TebLocalPlannerROS/obstacles"
PERSON = Cylinder(0.25, (1.8, -2.2), (0.0, 1.0))
WALL = [(2.6, -3.0, 2.6, 3.0)]
FRAMES = ("front_laser_link", "back_laser_link")


class FakeRobot(Node):
    """A robot standing at the odom origin, its two lidars seeing PERSON walk past a wall."""

    def __init__(self, context):
        super().__init__("fake_robot", context=context)
        StaticTransformBroadcaster(self).send_transform(
            [transform("base_link", frame, self.get_clock().now().to_msg(), mount[0], mount[1], mount[2], 0.15)
             for frame, (mount, _) in zip(FRAMES, lidars())])
        self.tf_pub = TransformBroadcaster(self)
        self.scan_pubs = [self.create_publisher(LaserScan, f"/{frame.split('_link')[0]}/{frame.split('_')[0]}_scan",
                                                qos_profile_sensor_data) for frame in FRAMES]
        self.started = time.monotonic()
        self.rng = np.random.default_rng(5)
        self.create_timer(0.1, self.tick)

    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def tick(self) -> None:
        stamp = self.get_clock().now().to_msg()
        self.tf_pub.send_transform(transform("odom", "base_link", stamp, 0.0, 0.0, 0.0))
        scans = scans_at((0.0, 0.0, 0.0), self.elapsed(), [PERSON], WALL, rng=self.rng)
        for pub, frame, scan, (_, params) in zip(self.scan_pubs, FRAMES, scans, lidars()):
            msg = LaserScan()
            msg.header.frame_id, msg.header.stamp = frame, stamp
            msg.angle_min, msg.angle_max = params.angle_min, params.angle_max
            msg.angle_increment = (params.angle_max - params.angle_min) / (params.samples - 1)
            msg.range_min, msg.range_max = params.range_min, params.range_max
            msg.ranges = scan.ranges.astype(np.float32).tolist()
            pub.publish(msg)


def obstacle(points, radius=0.0, vx=0.0, vy=0.0, ident=7) -> ObstacleMsg:
    msg = ObstacleMsg(radius=radius, id=ident)
    msg.polygon.points = [Point32(x=float(x), y=float(y)) for x, y in points]
    msg.velocities.twist.linear.x, msg.velocities.twist.linear.y = vx, vy
    return msg


@pytest.fixture
def lab():
    context = Context()
    rclpy.init(context=context)
    spec = next(n for n in load_launch("navigation").nodes if n.name == "move_base")
    parameters = dict(spec.parameters, use_sim_time=False, **{"obstacle_tracking.enabled": True})
    overrides = [Parameter(name, value=value) for name, value in parameters.items()]
    move_base = MoveBaseNode(context=context, parameter_overrides=overrides)
    robot = FakeRobot(context)
    listener = Node("listener", context=context)
    received: list[ObstacleArrayMsg] = []
    listener.create_subscription(ObstacleArrayMsg, TRACKS, received.append, 10)
    listener.in_robot_frame = []      # the collision monitor's copy (obstacle_tracks/robot_frame)
    listener.create_subscription(ObstacleArrayMsg, f"{TRACKS}/robot_frame", listener.in_robot_frame.append, 10)
    executor = SingleThreadedExecutor(context=context)
    for node in (move_base, robot, listener):
        executor.add_node(node)
    yield move_base, robot, listener, received, executor
    executor.shutdown()
    for node in (move_base, robot, listener):
        node.destroy_node()
    rclpy.shutdown(context=context)


def spin_until(executor, done, timeout: float) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end and not done():
        executor.spin_once(timeout_sec=0.02)


def test_a_person_walking_past_is_published_with_one_id_and_its_marks_cleared(lab):
    move_base, robot, listener, received, executor = lab
    spin_until(executor, lambda: robot.elapsed() > 4.0, 30.0)
    moving = [(msg, o) for msg in received for o in msg.obstacles]
    assert moving, f"no moving obstacle in {len(received)} messages on {TRACKS}"
    by_stamp = {(m.header.stamp.sec, m.header.stamp.nanosec): m for m in listener.in_robot_frame}
    copy = by_stamp[(moving[-1][0].header.stamp.sec, moving[-1][0].header.stamp.nanosec)]
    assert copy.header.frame_id == "base_link"      # the robot stands at odom's origin: the same numbers
    assert [c for o in copy.obstacles for p in o.polygon.points for c in (p.x, p.y)] == pytest.approx(
        [c for o in moving[-1][0].obstacles for p in o.polygon.points for c in (p.x, p.y)])
    assert {o.id for _, o in moving} == {moving[0][1].id}
    msg, last = moving[-1]
    assert msg.header.frame_id == "odom"
    assert abs(last.velocities.twist.linear.y - 1.0) < 0.2 and abs(last.velocities.twist.linear.x) < 0.2
    assert len(last.polygon.points) == 1 and last.radius > 0.1
    feed = move_base.obstacle_feed.moving_obstacles(move_base.controller._now(), "odom")
    rows = feed.rows
    assert feed.covariance.shape == (1, 4, 4) and np.all(np.linalg.eigvalsh(feed.covariance[0]) > 0)
    true = truth_at(robot.elapsed(), [PERSON])[0][0]
    assert len(rows) == 1 and np.hypot(*(rows[0, :2] - true)) < 0.3
    costmap = move_base.local_costmap
    with costmap.lock:
        grid = costmap.costmap
        xs, ys = np.meshgrid(np.arange(grid.size_x), np.arange(grid.size_y))
        wx, wy = grid.origin_x + (xs + 0.5) * grid.resolution, grid.origin_y + (ys + 0.5) * grid.resolution
        passed = (np.abs(wx - PERSON.start[0]) < 0.45) & (wy < true[1] - 1.5)
        assert not (grid.costmap[passed] == LETHAL_OBSTACLE).any(), "marks left on the person's path"


def test_other_nodes_obstacles_are_used_and_bad_ones_dropped(lab):
    move_base, robot, listener, _received, executor = lab
    publisher = listener.create_publisher(ObstacleArrayMsg, OBSTACLES, 10)
    spin_until(executor, lambda: robot.elapsed() > 0.5, 10.0)
    msg = ObstacleArrayMsg()
    msg.header.frame_id = "base_link"
    msg.header.stamp = listener.get_clock().now().to_msg()
    msg.obstacles = [obstacle([(1.0, 1.0), (1.2, 1.0), (1.1, 1.2)], 0.1, 0.5, 0.0),
                     obstacle([(math.nan, 0.0)]), obstacle([]), obstacle([(0.0, 0.0)], radius=-1.0),
                     obstacle([(0.0, 0.0)], vx=math.inf)]
    publisher.publish(msg)
    unknown = ObstacleArrayMsg(obstacles=[obstacle([(3.0, 3.0)])])
    unknown.header.frame_id = "nowhere"
    external = move_base.external_obstacles
    spin_until(executor, lambda: len(external.moving_obstacles(move_base.controller._now())) > 0, 5.0)
    publisher.publish(unknown)
    spin_until(executor, lambda: False, 0.2)
    rows = external.moving_obstacles(move_base.controller._now()).rows
    assert len(rows) == 1
    x, y, vx, vy, radius = rows[0]
    assert abs(x - 1.1) < 0.2 and abs(y - 1.0667) < 0.05 and (vx, vy) == (0.5, 0.0) and 0.2 < radius < 0.25
    external.timeout = 0.5
    assert len(external.moving_obstacles(move_base.controller._now() + 2.0)) == 0


def test_a_map_marking_the_persons_path_static_keeps_it_from_moving(lab):
    """What a map knows to be static is never a moving track: here a map (in odom) whose occupied cells cover the
    strip the person walks along."""
    move_base, robot, listener, received, executor = lab
    grid = OccupancyGrid()
    grid.header.frame_id = "odom"
    grid.info.resolution, grid.info.width, grid.info.height = 0.1, 20, 80
    grid.info.origin.position.x, grid.info.origin.position.y = PERSON.start[0] - 1.0, -4.0
    grid.info.origin.orientation.w = 1.0
    grid.data = [100] * (20 * 80)
    publisher = listener.create_publisher(OccupancyGrid, "/map", LATCHED)
    publisher.publish(grid)
    spin_until(executor, lambda: robot.elapsed() > 4.0, 30.0)
    assert received, f"no message on {TRACKS}"
    assert not any(msg.obstacles for msg in received), "a track moved on the map's static cells"
    assert len(move_base.obstacle_feed.moving_obstacles(move_base.controller._now(), "odom")) == 0


def test_a_hostile_map_is_refused_with_a_reason_and_tracking_goes_on(lab):
    """A map another node publishes may be wrong: too few cells for its size, a resolution that is no number, or
    more cells than the bound. Each is refused with a warning naming why; the walking person is still tracked."""
    move_base, robot, listener, received, executor = lab
    warned: list[str] = []
    tracking = move_base.obstacle_tracking
    original = tracking._warn
    tracking._warn = lambda key, text: (warned.append(text), original(key, text))
    publisher = listener.create_publisher(OccupancyGrid, "/map", LATCHED)
    for width, height, resolution, cells in ((10, 10, 0.1, 5), (10, 10, math.nan, 100), (2001, 2000, 0.05, 0)):
        grid = OccupancyGrid()
        grid.header.frame_id = "odom"
        grid.info.width, grid.info.height, grid.info.resolution = width, height, resolution
        grid.data = [100] * cells
        publisher.publish(grid)
        spin_until(executor, lambda: False, 0.3)
    said = "\n".join(warned)
    for reason in ("5 cells for 10 x 10", "cells of nan m", "more than obstacle tracking's bound of 4000000"):
        assert reason in said, said
    spin_until(executor, lambda: robot.elapsed() > 4.0, 30.0)
    assert any(msg.obstacles for msg in received), "no moving track after the hostile maps"


def test_tracks_given_in_another_frame_are_moved_and_turned():
    """The robot-frame copy: a track 1 m ahead in odom, walking left, as seen from a frame whose pose in it is
    (2, 0, 90 degrees): positions moved, velocities and their covariance turned."""
    track = Track(id=3, position=np.array([1.0, 0.0]), velocity=np.array([0.0, 1.0]),
                  covariance=np.diag([0.1, 0.1, 0.04, 0.01]), radius=0.3, age=1.0, confirmed=True, moving=True,
                  stamp=0.0)
    msg = obstacle_array_msg([track], "base_link", TimeMsg(), into=(2.0, 0.0, math.pi / 2))
    (obstacle,) = msg.obstacles
    point, velocity = obstacle.polygon.points[0], obstacle.velocities.twist.linear
    assert (point.x, point.y, velocity.x, velocity.y) == pytest.approx((2.0, 1.0, -1.0, 0.0), abs=1e-6)
    covariance = np.reshape(obstacle.velocities.covariance, (6, 6))[:2, :2]
    assert covariance == pytest.approx(np.diag([0.01, 0.04]), abs=1e-12)
    assert msg.header.frame_id == "base_link" and obstacle.radius == pytest.approx(0.3)
