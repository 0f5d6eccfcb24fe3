"""The simulator node with moving obstacles: /sim/moving_obstacles, the collision kinds on
/simplebot/collisions, and the warning about an unknown world key in the log."""

import time

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from rcl_interfaces.msg import Log
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from simplebot_navigation.scenarios.session import ScenarioClient

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
# The robot starts at (1, 2) facing +y; a cylinder walks at it from behind (0.5 m/s) and a box stays put.
WORLD = """\
name: walkers
start: {x: 1.0, y: 2.0, yaw: 1.5707963}
moving:
  - {shape: cylinder, radius: 0.25, height: 1.5, name: walker, keyframes: [[0, 1.0, -1.0], [6, 1.0, 2.0]]}
  - {shape: box, size: [0.4, 0.8], keyframes: [[0, 5.0, 2.0], [1, 5.0, 2.0]]}
movng: []
"""


@pytest.fixture(scope="module")
def stepper(context, tmp_path_factory):
    path = tmp_path_factory.mktemp("worlds") / "walkers.yaml"
    path.write_text(WORLD)
    sim = SimulatorNode(context=context, parameter_overrides=[
        Parameter("world", value=str(path)), Parameter("real_time_factor", value=0.0)])
    probe = Node("probe", context=context)
    seen = {"markers": [], "collisions": [], "log": []}
    probe.create_subscription(MarkerArray, "/sim/moving_obstacles", seen["markers"].append, 10)
    probe.create_subscription(DiagnosticStatus, "/simplebot/collisions", seen["collisions"].append, LATCHED)
    probe.create_subscription(Log, "/rosout", seen["log"].append,
                              QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    client = ScenarioClient(context)   # what the scenario runner reads the collisions with
    executor = SingleThreadedExecutor(context=context)
    for node in (sim, probe, client):
        executor.add_node(node)

    def pump(done, timeout=5.0):
        deadline = time.monotonic() + timeout
        while not done():
            assert time.monotonic() < deadline, "messages did not arrive"
            executor.spin_once(timeout_sec=0.01)

    pump(lambda: seen["collisions"] and sim.count_subscribers("/sim/moving_obstacles") >= 1)
    seen["client"] = client
    yield sim, seen, pump
    executor.shutdown()
    for node in (client, probe, sim):
        node.destroy_node()


def test_markers_follow_the_obstacles_in_odom(stepper):
    sim, seen, pump = stepper
    sim.advance(1.0)
    pump(lambda: len(seen["markers"]) >= 10)
    msg = seen["markers"][-1]
    bodies = [m for m in msg.markers if m.ns == "moving_obstacles"]
    arrows = [m for m in msg.markers if m.ns == "moving_velocity"]
    assert [(m.id, m.type) for m in bodies] == [(0, Marker.CYLINDER), (1, Marker.CUBE)]
    assert {m.header.frame_id for m in msg.markers} == {"odom"}
    walker, box = bodies
    # At t = 1 s the walker is at (1, -0.5) in the world: 2.5 m behind the start, which faces +y.
    assert (walker.pose.position.x, walker.pose.position.y) == pytest.approx((-2.5, 0.0), abs=1e-6)
    assert (walker.scale.x, walker.scale.z, walker.pose.position.z) == pytest.approx((0.5, 1.5, 0.75))
    assert (box.pose.position.x, box.pose.position.y) == pytest.approx((0.0, -4.0), abs=1e-6)
    assert (box.scale.x, box.scale.y) == pytest.approx((0.4, 0.8))
    tip = arrows[0].points[1]
    assert (tip.x, tip.y) == pytest.approx((-2.5 + 0.5, 0.0), abs=1e-6)   # 0.5 m/s along odom's +x
    assert msg.markers[0].header.stamp.sec == 1


def test_a_strike_on_the_standing_robot_is_reported_as_such(stepper):
    sim, seen, pump = stepper
    sim.advance(5.0 - sim.sim.sim_time)
    pump(lambda: seen["collisions"][-1].values[0].value != "0")
    report = {kv.key: kv.value for kv in seen["collisions"][-1].values}
    assert (report["count"], report["count_moving"], report["count_standing"]) == ("1", "0", "1")
    assert (report["last_kind"], report["last_obstacle"]) == ("standing", "moving[0] (walker)")
    assert "struck 1 time(s) while standing" in seen["collisions"][-1].message
    pump(lambda: seen["client"].struck_standing == 1)
    assert seen["client"].collisions == 0


def test_the_unknown_world_key_is_logged_with_a_suggestion(stepper):
    _, seen, pump = stepper
    pump(lambda: any("movng" in m.msg for m in seen["log"]))
    line = next(m for m in seen["log"] if "movng" in m.msg)
    assert line.msg == "walkers.yaml: unknown world key 'movng' (did you mean 'moving'?); ignored"
    assert line.level == Log.WARN
