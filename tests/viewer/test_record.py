"""MCAP recording of a run (read back with the mcap readers) and the --plot of it."""

import subprocess
import sys
import time

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from PIL import Image
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from simplebot_navigation.costmap.cost_values import OCCUPANCY_GRID_TABLE
from simplebot_navigation.launch.loader import LaunchError
from simplebot_navigation.launch.record import recorder_spec
from simplebot_navigation.ros.tools.raw_topics import message_definition
from simplebot_navigation.ros.tools.recorder import Recorder
from simplebot_navigation.launch.recording_plot import plot_recording
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from tests.viewer.conftest import FakeMoveBase, costmap_array

SECONDS = 1.0   # of simulated time, stepped in lockstep
CHUNK = 0.1
# Exact counts for SECONDS of a 100 Hz simulation: /clock every step, odometry and its /tf at 50 Hz,
# each lidar at 10 Hz; latched topics once.
EXACT = {"/clock": 100, "/simplebot_controller/odom": 50, "/simplebot/ground_truth": 50, "/tf": 50,
         "/front_laser/front_scan": 10, "/back_laser/back_scan": 10,
         "/tf_static": 1, "/robot_description": 1, "/global_costmap/costmap": 1}
SCHEMAS = {"/clock": "rosgraph_msgs/msg/Clock", "/tf": "tf2_msgs/msg/TFMessage",
           "/simplebot_controller/odom": "nav_msgs/msg/Odometry", "/front_laser/front_scan": "sensor_msgs/msg/LaserScan",
           "/global_costmap/costmap": "nav_msgs/msg/OccupancyGrid", "/move_base/GlobalPlanner/plan": "nav_msgs/msg/Path",
           "/move_base/TebLocalPlannerROS/teb_poses": "geometry_msgs/msg/PoseArray",
           "/move_base/status": "actionlib_msgs/msg/GoalStatusArray"}


@pytest.fixture(scope="module")
def recording(context, corridor, tmp_path_factory):
    """SECONDS of the corridor scenario recorded to an MCAP file; returns (path, recorder counts, final odometry)."""
    path = tmp_path_factory.mktemp("record") / "run.mcap"
    sim = SimulatorNode(context=context, parameter_overrides=[
        Parameter("world", value=corridor), Parameter("real_time_factor", value=0.0)])
    move_base = FakeMoveBase(context)
    recorder = Recorder(path=str(path), context=context)
    executor = SingleThreadedExecutor(context=context)
    for node in (sim, move_base, recorder):
        executor.add_node(node)

    def pump(done, what):
        deadline = time.monotonic() + 10.0
        while not done():
            assert time.monotonic() < deadline, f"timed out waiting for {what}"
            executor.spin_once(timeout_sec=0.01)

    robot = sim.robots[0]
    publishers = [sim.clock_pub, robot.odom_pub, robot.truth_pub, sim.tf_broadcaster._pub, *robot.scan_pubs.values()]

    def subscribed():
        recorder.discover()
        return all(topic in recorder.counts for topic in EXACT) and \
            all(p.get_subscription_count() >= 1 for p in publishers)

    pump(subscribed, "the recorder to subscribe to every topic")
    pump(lambda: all(recorder.counts[t] == 1 for t in ("/tf_static", "/robot_description",
                                                        "/global_costmap/costmap")), "latched topics")
    for _ in range(round(SECONDS / CHUNK)):
        sim.advance(CHUNK)
        due = round(sim.sim.sim_time * 100)
        pump(lambda: recorder.counts["/clock"] == due, "every /clock message")
    pump(lambda: all(recorder.counts[t] == n for t, n in EXACT.items()), "every message")
    odom = sim.sim.odometry()
    counts = dict(recorder.counts)
    executor.shutdown()
    for node in (recorder, move_base, sim):
        node.destroy_node()
    return path, counts, odom


def test_recorded_topics_counts_and_schemas(recording):
    path, counts, _ = recording
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        header, summary = reader.get_header(), reader.get_summary()
    assert header.profile == "ros2"
    channels = {c.topic: c for c in summary.channels.values()}
    recorded = {topic: summary.statistics.channel_message_counts.get(c.id, 0) for topic, c in channels.items()}
    for topic, n in EXACT.items():
        assert recorded[topic] == n, topic
    assert recorded == counts  # the file's summary agrees with what the recorder wrote
    assert recorded["/move_base/GlobalPlanner/plan"] >= 1
    for topic, type_name in SCHEMAS.items():
        schema = summary.schemas[channels[topic].schema_id]
        assert (schema.name, schema.encoding, channels[topic].message_encoding) == (type_name, "ros2msg", "cdr")
        assert schema.data.decode() == message_definition(type_name)
    assert not any(t.split("/")[1].startswith("_") for t in channels)  # hidden topics are left out
    # the publishers' QoS, as ros2 bag play reads it: /tf_static replays latched, scans best effort
    tf_static = yaml.safe_load(channels["/tf_static"].metadata["offered_qos_profiles"])
    assert tf_static and all(p["durability"] == 1 and p["reliability"] == 1 for p in tf_static)
    scan = yaml.safe_load(channels["/front_laser/front_scan"].metadata["offered_qos_profiles"])
    assert scan[0]["reliability"] == 2 and scan[0]["deadline"] == {"sec": 2147483647, "nsec": 4294967295}


def test_recorded_messages_decode_to_what_was_sent(recording):
    path, _, odom = recording
    last = {}
    with open(path, "rb") as stream:
        for _, channel, _, msg in make_reader(stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            last[channel.topic] = msg
    grid = last["/global_costmap/costmap"]
    expected = OCCUPANCY_GRID_TABLE[costmap_array()].ravel()
    assert np.array_equal(np.asarray(grid.data, dtype=np.int8), expected)
    pose = last["/simplebot_controller/odom"].pose.pose.position
    assert (pose.x, pose.y) == (odom.x, odom.y)
    scan = last["/front_laser/front_scan"]
    assert scan.header.frame_id == "front_laser_link" and len(scan.ranges) == 683
    assert last["/clock"].clock.sec == round(SECONDS) and last["/clock"].clock.nanosec == 0


def test_plot_of_a_recorded_run(recording, tmp_path):
    path, _, _ = recording
    png = tmp_path / "run.png"
    result = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch.record", "--plot", str(path),
                             str(png)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "costmap True" in result.stdout and "odometry 50" in result.stdout
    with Image.open(png) as image:
        assert image.size[0] == 990  # 9 in at 110 dpi; the height follows the run's extent
        colours = np.asarray(image.convert("RGB")).reshape(-1, 3)
    assert len(np.unique(colours, axis=0)) > 20  # a picture, not a blank page


def test_plot_names_a_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such recording"):
        plot_recording(str(tmp_path / "none.mcap"), str(tmp_path / "out.png"))


def test_record_option_checks_the_target(tmp_path):
    spec = recorder_spec(str(tmp_path / "run.mcap"))
    assert (spec.pkg, spec.type, spec.parameters) == ("python", "simplebot_navigation.ros.tools.recorder:Recorder",
                                                      {"path": str(tmp_path / "run.mcap")})
    with pytest.raises(LaunchError, match="does not exist"):
        recorder_spec(str(tmp_path / "missing" / "run.mcap"))
    with pytest.raises(LaunchError, match="must end in .mcap"):
        recorder_spec(str(tmp_path / "run.bag"))
