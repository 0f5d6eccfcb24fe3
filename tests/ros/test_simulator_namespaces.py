"""The simulator node with several robots: each under its namespace, frames prefixed, one map frame."""

import time

import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from simplebot_navigation.ros.simulator.simulator_robot import LATCHED


@pytest.fixture
def two_robots(context):
    sim = SimulatorNode(context=context, parameter_overrides=[
        Parameter("world", value="empty"), Parameter("real_time_factor", value=0.0),
        Parameter("namespaces", value="robot1 robot2"), Parameter("starts", value="0,0,0;3,0,0")])
    probe = Node("probe", context=context)
    seen = {"static": [], "tf": [], "scan": [], "odom": []}
    probe.create_subscription(TFMessage, "/tf_static", lambda m: seen["static"].extend(m.transforms), LATCHED)
    probe.create_subscription(TFMessage, "/tf", lambda m: seen["tf"].extend(m.transforms), 100)
    probe.create_subscription(LaserScan, "/robot1/front_laser/front_scan", seen["scan"].append,
                              qos_profile_sensor_data)
    probe.create_subscription(Odometry, "/robot2/simplebot_controller/odom", seen["odom"].append, 10)
    cmd_vel = probe.create_publisher(Twist, "/robot2/simplebot_controller/cmd_vel", 10)
    executor = SingleThreadedExecutor(context=context)
    for node in (sim, probe):
        executor.add_node(node)

    def pump(done):
        deadline = time.monotonic() + 10.0
        while not done():
            assert time.monotonic() < deadline, "timed out"
            executor.spin_once(timeout_sec=0.01)

    # /tf_static may also carry what simulators of earlier tests latched: wait for this one's
    pump(lambda: any(t.child_frame_id == "robot2/odom" for t in seen["static"]) and sim.count_subscribers("/robot1/front_laser/front_scan") >= 1
         and cmd_vel.get_subscription_count() >= 1)
    yield sim, seen, cmd_vel, pump
    executor.shutdown()
    for node in (probe, sim):
        node.destroy_node()


def test_each_robot_has_its_topics_and_prefixed_frames(two_robots):
    sim, seen, _, pump = two_robots
    static = {(t.header.frame_id, t.child_frame_id): t.transform.translation for t in seen["static"]}
    assert static[("map", "robot2/odom")].x == 3.0 and static[("map", "robot1/odom")].x == 0.0
    assert ("robot2/base_link", "robot2/front_laser_link") in static
    assert not any(parent == "base_link" for parent, _ in static), "an unprefixed frame"
    sim.advance(0.1)
    pump(lambda: seen["scan"] and seen["odom"] and seen["tf"])
    assert seen["scan"][-1].header.frame_id == "robot1/front_laser_link"
    assert seen["scan"][-1].ranges[341] < 3.0  # robot2 stands 3 m ahead
    odom = seen["odom"][-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("robot2/odom", "robot2/base_link")
    assert {(t.header.frame_id, t.child_frame_id) for t in seen["tf"]} >= {("robot1/odom", "robot1/base_link"),
                                                                           ("robot2/odom", "robot2/base_link")}
    published = {publisher.topic_name for publisher in sim.publishers}  # not the graph: other tests' simulators linger
    for topic in ("/robot1/simplebot/collisions", "/robot2/simplebot/ground_truth", "/robot2/robot_description"):
        assert topic in published
    assert sorted(t for t in published if not t.startswith(("/robot1/", "/robot2/"))) == [
        "/clock", "/parameter_events", "/tf", "/tf_static"]


def test_a_command_drives_only_its_robot(two_robots):
    sim, seen, cmd_vel, pump = two_robots
    twist = Twist()
    twist.linear.x = 0.5
    for _ in range(20):
        cmd_vel.publish(twist)
        received = len(seen["odom"])
        sim.advance(0.05)
        pump(lambda: len(seen["odom"]) > received)  # spins, so the command is taken before the next advance
    assert sim.sim.ground_truth(1).x > 3.2
    assert sim.sim.ground_truth(0).x == pytest.approx(0.0, abs=1e-3)


def test_bad_starts_stop_the_node_with_the_reason(context):
    with pytest.raises(ValueError, match=r"parameter 'starts': 2 robots but 1 start\(s\) in the starts argument"):
        SimulatorNode(context=context, parameter_overrides=[
            Parameter("world", value="empty"), Parameter("namespaces", value="robot1 robot2"),
            Parameter("starts", value="0,0,0")])


def test_with_a_localizer_the_simulator_leaves_map_to_odom_to_it(context):
    """map_to_odom:=false (navigation on a map): amcl publishes map -> robot1/odom, so the simulator must not."""
    sim = SimulatorNode(context=context, parameter_overrides=[
        Parameter("world", value="empty"), Parameter("real_time_factor", value=0.0),
        Parameter("namespaces", value="robot7"), Parameter("map_to_odom", value=False)])
    probe = Node("probe", context=context)
    static = []
    probe.create_subscription(TFMessage, "/tf_static", lambda m: static.extend(m.transforms), LATCHED)
    executor = SingleThreadedExecutor(context=context)
    for node in (sim, probe):
        executor.add_node(node)
    try:
        deadline = time.monotonic() + 10.0
        while not any(t.child_frame_id == "robot7/front_laser_link" for t in static):
            assert time.monotonic() < deadline, "timed out waiting for the static transforms"
            executor.spin_once(timeout_sec=0.01)
        assert not any(t.child_frame_id == "robot7/odom" for t in static)
    finally:
        executor.shutdown()
        for node in (probe, sim):
            node.destroy_node()
