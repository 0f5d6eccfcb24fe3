"""The amcl node, with the shipped config/map/amcl.yaml, in lockstep with the simulator and map_server on the lab: it
localizes a robot whose encoders drift, publishes map -> odom, takes initial poses and its services, refuses bad parameters, and shrugs off hostile
messages."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rclpy.time import Time
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty
from tf2_msgs.msg import TFMessage

from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.maps import OccupancyMap
from simplebot_navigation.parameters import fields_of
from simplebot_navigation.paths import package_share
from simplebot_navigation.ros.amcl.amcl_messages import post_dated
from simplebot_navigation.ros.amcl.amcl_node import LATCHED, AmclNode
from simplebot_navigation.ros.conversions import occupancy_map_msg, yaw_of
from simplebot_navigation.ros.map_server_node import WORLD_MAP_RESOLUTION, MapServerNode
from simplebot_navigation.ros.simulator.lockstep import LockstepDriver
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from simplebot_navigation.ros.tf import TransformException
from simplebot_navigation.sim import load_world
from simplebot_navigation.sim.map_export import export_map

pytestmark = pytest.mark.timeout(180)


class Probe(Node):
    def __init__(self, context):
        super().__init__("amcl_probe", context=context)
        self.poses: list[PoseWithCovarianceStamped] = []
        self.clouds: list[PoseArray] = []
        self.logs: list[str] = []
        self.scan_stamps: set[int] = set()              # ns, of both lidars' scans
        self.map_to_odom_stamps: list[int] = []         # ns, of amcl's map -> odom on /tf
        self.create_subscription(PoseWithCovarianceStamped, "/amcl_pose", self.poses.append, LATCHED)
        self.create_subscription(TFMessage, "/tf", self._on_tf, 100)
        for topic in ("/front_laser/front_scan", "/back_laser/back_scan"):
            self.create_subscription(LaserScan, topic, lambda m: self.scan_stamps.add(Time.from_msg(
                m.header.stamp).nanoseconds), qos_profile_sensor_data)
        self.create_subscription(PoseArray, "/particle_cloud", self.clouds.append, 1)
        self.create_subscription(Log, "/rosout", lambda m: self.logs.append(m.msg), 100)
        self.initial_pose = self.create_publisher(PoseWithCovarianceStamped, "/initialpose", 10)
        self.front = self.create_publisher(LaserScan, "/front_laser/front_scan", qos_profile_sensor_data)
        self.map = self.create_publisher(OccupancyGrid, "/map", LATCHED)

    def _on_tf(self, msg: TFMessage) -> None:
        self.map_to_odom_stamps += [Time.from_msg(t.header.stamp).nanoseconds for t in msg.transforms
                                    if (t.header.frame_id, t.child_frame_id) == ("map", "odom")]


def shipped_parameters(**extra) -> list[Parameter]:
    """config/map/amcl.yaml, on the simulator's clock."""
    shipped = yaml.safe_load((Path(package_share("simplebot_navigation")) / "config/map/amcl.yaml").read_text())
    return [Parameter(name, value=value) for name, value in {"use_sim_time": True, **shipped, **extra}.items()]


@pytest.fixture(scope="module")
def lab(context):
    sim = SimulatorNode(context=context, parameter_overrides=[
        Parameter("world", value="lab"), Parameter("real_time_factor", value=0.0),
        Parameter("odom_scale_std", value=0.02), Parameter("seed", value=3)])
    map_server = MapServerNode(context=context, parameter_overrides=[Parameter("yaml_filename", value="lab")])
    amcl = AmclNode(context=context, parameter_overrides=shipped_parameters())
    probe = Probe(context)
    driver = LockstepDriver(sim, [map_server, amcl, probe])
    yield sim, amcl, probe, driver
    driver.executor.shutdown()
    for node in (probe, amcl, map_server, sim):
        node.destroy_node()


def drive(sim, driver, v, w, seconds):
    end = driver.time + seconds
    while driver.time < end - 1e-9:
        sim.sim.set_cmd_vel(v, w)
        driver.run_until(min(end, driver.time + 0.1))


def pose_error(sim, amcl) -> tuple[float, float]:
    truth, estimate = sim.sim.ground_truth(), amcl.amcl.estimate()
    return (math.hypot(estimate.x - truth.x, estimate.y - truth.y),
            abs(math.remainder(estimate.yaw - truth.yaw, 2 * math.pi)))


def covariance(xx=0.25, yy=0.25, aa=0.07) -> list[float]:
    out = [0.0] * 36
    out[0], out[7], out[35] = xx, yy, aa
    return out


def initial_pose_msg(x, y, yaw, frame="map", cov=None) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = frame
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    msg.pose.covariance = covariance() if cov is None else cov
    return msg


def test_it_localizes_a_drifting_robot_and_publishes_map_to_odom(lab):
    sim, amcl, probe, driver = lab
    driver.run_until(1.0, stop=lambda: probe.poses)
    assert probe.poses and probe.poses[-1].header.frame_id == "map"
    drive(sim, driver, 0.4, 0.03, 7.0)     # along the corridor
    error, yaw_error = pose_error(sim, amcl)
    assert error < 0.1 and yaw_error < math.radians(3)
    odom = sim.sim.odometry()
    truth = sim.sim.ground_truth()
    assert math.hypot(odom.x - truth.x, odom.y - truth.y) > error       # the encoders drift, amcl does not
    tf = amcl.tf.lookup_transform("map", "base_link", Time())
    assert math.hypot(tf.transform.translation.x - truth.x, tf.transform.translation.y - truth.y) < 0.15
    # post-dated by transform_tolerance: stamped the newest scan's stamp + 0.2 s, so that move_base, asking for map
    # -> base_link at its own later time, does not fail for lack of a transform newer than the last scan
    tolerance_ns = round(amcl.params.transform_tolerance * 1e9)
    assert tolerance_ns == 200_000_000
    assert abs(max(probe.map_to_odom_stamps) - (max(probe.scan_stamps) + tolerance_ns)) < 1000
    saved = amcl.get_parameter("initial_pose_x").value, amcl.get_parameter("initial_pose_y").value
    assert math.hypot(saved[0] - truth.x, saved[1] - truth.y) < 0.8     # save_pose_rate 0.5 Hz: at most 2 s old


def test_a_wrong_initial_pose_is_taken_and_driving_corrects_it(lab):
    sim, amcl, probe, driver = lab
    truth = sim.sim.ground_truth()
    wrong = (truth.x + 0.4, truth.y - 0.3)
    probe.initial_pose.publish(initial_pose_msg(*wrong, truth.yaw + 0.25))     # RViz's spread: 0.5 m, 15 deg

    def taken():
        particles = amcl.amcl.particles[:, :2]
        mean = particles.mean(axis=0)
        return math.hypot(mean[0] - wrong[0], mean[1] - wrong[1]) < 0.1 and min(particles.std(axis=0)) > 0.3
    assert driver.run_until(driver.time + 1.0, stop=taken), "the initial pose was not taken"
    errors = []
    for _ in range(16):                     # back along the corridor, whose walls say little about x
        drive(sim, driver, -0.3, -0.03, 0.5)
        errors.append(pose_error(sim, amcl))
    error, yaw_error = np.median(errors[-8:], axis=0)
    assert error < 0.08 and yaw_error < math.radians(3)


def test_hostile_initial_poses_scans_and_parameters_change_nothing(lab):
    sim, amcl, probe, driver = lab
    before = amcl.amcl.particles
    probe.initial_pose.publish(initial_pose_msg(float("nan"), 0.0, 0.0))
    probe.initial_pose.publish(initial_pose_msg(0.0, 0.0, 0.0, cov=covariance(xx=-1.0)))
    probe.initial_pose.publish(initial_pose_msg(0.0, 0.0, 0.0, frame="no_such_tool_frame"))
    probe.initial_pose.publish(initial_pose_msg(1e308, 0.0, 0.0))
    probe.initial_pose.publish(initial_pose_msg(0.0, 0.0, 0.0, cov=covariance(xx=1e308, yy=1e308)))
    bad_map = OccupancyGrid()
    bad_map.info.width, bad_map.info.height, bad_map.info.resolution = 2, 2, 0.05
    bad_map.info.origin.position.x, bad_map.data = float("nan"), [0, 0, 0, 0]
    probe.map.publish(bad_map)
    scan = LaserScan()
    scan.angle_increment, scan.range_max, scan.ranges = 0.01, 5.6, [1.0] * 10
    scan.header.frame_id, scan.header.stamp = "front_laser_link", Time(seconds=1e9).to_msg()   # far ahead
    probe.front.publish(scan)
    driver.run_until(driver.time + 0.05)
    assert np.array_equal(amcl.amcl.particles, before)
    text = "\n".join(probe.logs)
    assert "initialpose ignored: pose.position.x is nan" in text
    assert "initialpose ignored: initial pose covariance: must be positive definite" in text
    assert any(line.startswith("initialpose ignored:") and "no_such_tool_frame" in line for line in probe.logs)
    assert "initialpose ignored: (1e+308, 0) is outside the map" in text
    assert "initialpose ignored: pose.covariance is wider than the map" in text
    assert "map ignored:" in text
    refused = amcl.set_parameters([Parameter("max_particles", value=10 ** 12)])[0]
    assert not refused.successful and "max_particles" in refused.reason
    refused = amcl.set_parameters([Parameter("odom_model_type", value="diff")])[0]
    assert not refused.successful and "requires restart" in refused.reason
    refused = amcl.set_parameters([Parameter("min_particles", value=amcl.params.max_particles + 1)])[0]
    assert not refused.successful and "min_particles" in refused.reason
    assert amcl.set_parameters([Parameter("laser_max_beams", value=30)])[0].successful
    assert amcl.amcl.params.laser_max_beams == 30


def test_a_scan_in_an_unknown_frame_is_dropped_with_its_topic_and_frame_named(lab):
    sim, amcl, probe, driver = lab
    before = amcl.amcl.particles
    scan = LaserScan()
    scan.header.frame_id, scan.header.stamp = "no_such_laser_link", amcl.get_clock().now().to_msg()
    scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = -1.0, 0.01, 0.2, 5.6
    scan.ranges = [1.0] * 200                     # a good scan but for its frame
    probe.front.publish(scan)
    driver.run_until(driver.time + 0.05)
    dropped = [line for line in probe.logs if line.startswith("front_laser/front_scan: scan dropped:")
               and '"no_such_laser_link"' in line]
    assert dropped, probe.logs[-5:]
    assert np.array_equal(amcl.amcl.particles, before)


def test_time_going_back_restarts_the_filter_round_its_estimate(lab):
    sim, amcl, probe, driver = lab
    scan = LaserScan()
    scan.header.frame_id = "front_laser_link"
    scan.header.stamp = Time(seconds=max(0.0, driver.time - 5.0)).to_msg()
    scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = -1.0, 0.01, 0.2, 5.6
    scan.ranges = [2.0] * 200
    probe.front.publish(scan)
    driver.run_until(driver.time + 0.3)
    assert any("time went back" in line for line in probe.logs), probe.logs[-5:]
    drive(sim, driver, 0.3, 0.0, 2.0)
    assert pose_error(sim, amcl)[0] < 0.15


def test_global_localization_spreads_the_particles_and_the_cloud_is_published(lab):
    sim, amcl, probe, driver = lab
    client = probe.create_client(Empty, "/global_localization")
    future = client.call_async(Empty.Request())
    driver.run_until(driver.time + 1.0, stop=future.done)
    assert future.done()
    spread = amcl.amcl.particles[:, :2].std(axis=0)
    assert len(amcl.amcl.particles) == amcl.params.max_particles and min(spread) > 2.0
    drive(sim, driver, 0.0, 0.3, 0.5)
    assert probe.clouds and probe.clouds[-1].header.frame_id == "map" and len(probe.clouds[-1].poses) > 0


def back_to_the_truth(sim, probe, driver) -> None:
    """The initial pose at the robot's true pose, as a test that disturbed the filter leaves it."""
    truth = sim.sim.ground_truth()
    probe.initial_pose.publish(initial_pose_msg(truth.x, truth.y, truth.yaw, cov=covariance(0.01, 0.01, 0.003)))
    drive(sim, driver, 0.0, 0.2, 1.0)


def test_a_burst_of_50_global_localization_calls_is_answered_in_full(lab):
    sim, amcl, probe, driver = lab
    client = probe.create_client(Empty, "/global_localization")
    futures = [client.call_async(Empty.Request()) for _ in range(50)]
    driver.run_until(driver.time + 5.0, stop=lambda: all(f.done() for f in futures))
    answered = sum(f.done() for f in futures)
    probe.destroy_client(client)
    back_to_the_truth(sim, probe, driver)
    assert answered == 50


def test_every_live_number_beyond_its_physical_bound_is_refused_naming_it_and_the_filter_goes_on(lab):
    sim, amcl, probe, driver = lab
    before = amcl.params
    specs = fields_of(AmclParams)
    numeric = [name for name, spec in specs.items() if spec.kind in (int, float) and spec.dynamic]
    for name in numeric:
        hostile = (2 ** 62, -2 ** 62) if specs[name].kind is int else (1e308, -1e308, float("nan"))
        for value in hostile:
            result = amcl.set_parameters([Parameter(name, value=value)])[0]
            assert not result.successful and name in result.reason and repr(value) in result.reason, \
                (name, value, result.reason)
    assert amcl.params == before
    # the largest legal post-dating: map -> odom still goes out, stamped the scan's stamp + 10 s
    assert amcl.set_parameters([Parameter("transform_tolerance", value=10.0)])[0].successful
    sent = len(probe.map_to_odom_stamps)
    drive(sim, driver, 0.0, 0.1, 0.5)
    assert len(probe.map_to_odom_stamps) > sent
    newest_scan = max(stamp for stamp in probe.scan_stamps if stamp <= driver.time * 1e9)   # not a hostile one
    assert abs(probe.map_to_odom_stamps[-1] - (newest_scan + 10 ** 10)) < 1000
    assert amcl.set_parameters([Parameter("transform_tolerance", value=0.2)])[0].successful


def test_map_to_odom_post_dated_past_the_latest_stamp_saturates_instead_of_raising():
    latest = (2 ** 31 - 1) * 10 ** 9 + 999_999_999     # the latest stamp a message can carry (sec is an int32)
    stamp = post_dated(latest - 10 ** 9, 10.0)      # a scan 1 s before the end of time, the largest tolerance
    assert (stamp.sec, stamp.nanosec) == (2 ** 31 - 1, 999_999_999)
    assert Time.from_msg(post_dated(5 * 10 ** 9, 0.2)).nanoseconds == 5_200_000_000


def lab_map_msg(driver, noisy_seed=None, occupied_at=None) -> OccupancyGrid:
    """The lab's map (noisy as a SLAM run's with a seed), with a 1 m square occupied round ``occupied_at``."""
    lab_map = export_map(load_world("lab"), WORLD_MAP_RESOLUTION, noisy_seed=noisy_seed)
    if occupied_at is not None:
        col, row = (int((v - o) / lab_map.resolution) for v, o in zip(occupied_at, lab_map.origin))
        lab_map.data[row - 10:row + 10, col - 10:col + 10] = 100
    return occupancy_map_msg(lab_map, Time(seconds=driver.time).to_msg())


def test_a_map_swap_and_back_keeps_amcl_localized_whatever_initial_cov_was_saved(lab):
    """initial_cov_* as wide as save_pose_rate leaves them after global localization (and no saving since): a new map
    must start from the filter's own spread, not from them."""
    sim, amcl, probe, driver = lab
    wide = [Parameter("save_pose_rate", value=-1.0), Parameter("initial_cov_xx", value=25.0),
            Parameter("initial_cov_yy", value=25.0), Parameter("initial_cov_aa", value=3.0)]
    assert all(result.successful for result in amcl.set_parameters(wide))
    try:
        for noisy_seed in (1, None):            # to a SLAM run's map of the lab and back
            before = amcl.amcl
            probe.map.publish(lab_map_msg(driver, noisy_seed=noisy_seed))
            assert driver.run_until(driver.time + 1.0, stop=lambda: amcl.amcl is not before)
            truth, particles = sim.sim.ground_truth(), amcl.amcl.particles
            assert max(particles[:, :2].std(axis=0)) < 0.5          # as sure as before, not spread 5 m wide
            assert np.linalg.norm(particles[:, :2].mean(axis=0) - (truth.x, truth.y)) < 0.2
            drive(sim, driver, 0.0, 0.4, 1.5)
            error, yaw_error = pose_error(sim, amcl)
            assert error < 0.2 and yaw_error < math.radians(10)
    finally:
        amcl.set_parameters([Parameter("save_pose_rate", value=0.5)])
        back_to_the_truth(sim, probe, driver)


def test_a_new_map_without_room_at_the_estimate_says_so(lab):
    sim, amcl, probe, driver = lab
    truth = sim.sim.ground_truth()
    probe.map.publish(lab_map_msg(driver, occupied_at=(truth.x, truth.y)))
    driver.run_until(driver.time + 0.2)
    assert any("is not in free space of the new map" in line for line in probe.logs), probe.logs[-5:]
    probe.map.publish(lab_map_msg(driver))
    back_to_the_truth(sim, probe, driver)


def test_a_map_beyond_the_bound_is_refused_naming_it_and_the_old_map_stays(lab):
    sim, amcl, probe, driver = lab
    before = amcl.amcl
    big = OccupancyMap(np.zeros((2000, 2001), np.int8), 0.05)
    probe.map.publish(occupancy_map_msg(big, Time(seconds=driver.time).to_msg()))
    driver.run_until(driver.time + 0.5)
    assert amcl.amcl is before
    assert any("map ignored: 2001 x 2000 = 4002000 cells, more than amcl's bound of 4000000" in line
               for line in probe.logs), probe.logs[-5:]
    drive(sim, driver, 0.0, 0.2, 0.5)
    assert pose_error(sim, amcl)[0] < 0.15
    probe.map.publish(lab_map_msg(driver))        # the latched map a later amcl gets


def test_a_respawned_amcl_starts_where_the_robot_is_not_from_the_launch_pose(lab, context, tmp_path, monkeypatch):
    """The launcher's run folder holds the last estimate; a new amcl (the launch's initial pose is the lab's start)
    resumes from it, though the robot drove on while no amcl ran."""
    sim, amcl, probe, driver = lab
    monkeypatch.setenv("SIMPLEBOT_RUN_DIR", str(tmp_path))
    driver.remove_node(amcl)                      # the fixture's amcl rests meanwhile
    truth = sim.sim.ground_truth()
    first = AmclNode(context=context, parameter_overrides=shipped_parameters(
        initial_pose_x=truth.x, initial_pose_y=truth.y, initial_pose_a=truth.yaw, save_pose_rate=2.0))
    driver.add_node(first)
    respawned = None
    try:
        drive(sim, driver, 0.0, 0.5, 3.0)
        assert (tmp_path / "amcl.pose.yaml").is_file()
        driver.remove_node(first)                 # killed
        first.destroy_node()
        first = None
        drive(sim, driver, 0.0, -0.5, 2.0)           # the odometry goes on while no amcl runs
        respawned = AmclNode(context=context, parameter_overrides=shipped_parameters())
        driver.add_node(respawned)
        driver.run_until(driver.time + 1.0, stop=lambda: respawned.amcl is not None and respawned._map_to_odom)
        truth = sim.sim.ground_truth()
        # the launch's initial pose, (0, 0, 0), is far from the truth
        assert math.hypot(truth.x, truth.y) > 0.5 and abs(math.remainder(truth.yaw, 2 * math.pi)) > 0.5
        error, yaw_error = pose_error(sim, respawned)
        assert error < 0.1 and yaw_error < math.radians(3)
    finally:
        for node in (first, respawned):
            if node is not None:
                driver.remove_node(node)
                node.destroy_node()
        driver.add_node(amcl)
        back_to_the_truth(sim, probe, driver)
