"""The simulator node on real topics: /clock drives other nodes, scans, TF, latched topics, driving, contacts, RTF."""

import math
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Log
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from simplebot_description import robot_description
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode, main as simulator_main
from simplebot_navigation.ros.tf import Buffer, TransformListener
from simplebot_navigation.sim.diff_drive import drive_for

BOX = robot_description("box")
WALL_FACE = 2.2  # x of the wall's near face; the robot starts at the origin facing +x
FRONT_LASER_X = 0.35
WHEEL_RADIUS = 0.07
CENTRE = 341  # beam at angle 0 of 683
CHUNK = 0.1  # sim seconds per lockstep round: one scan period


@pytest.fixture(scope="module")
def wall_world(tmp_path_factory):
    path = tmp_path_factory.mktemp("worlds") / "wall.yaml"
    x = WALL_FACE + 0.05
    path.write_text(f"name: wall\nwalls: [{{from: [{x}, -3.0], to: [{x}, 3.0], thickness: 0.1, height: 1.0}}]\n"
                    "boxes: []\ncylinders: []\nstart: {x: 0.0, y: 0.0, yaw: 0.0}\n")
    return str(path)


class Probe(Node):
    """A node on sim time that records what a navigation stack would subscribe to."""

    def __init__(self, context):
        super().__init__("probe", context=context, parameter_overrides=[Parameter("use_sim_time", value=True)])
        self.clock: list[Clock] = []
        self.odom: list[Odometry] = []
        self.scans: dict[str, list[LaserScan]] = {"front_laser_link": [], "back_laser_link": []}
        self.collisions: list[DiagnosticStatus] = []
        self.rosout: list[Log] = []
        self.create_subscription(Clock, "/clock", self.clock.append, 10)
        self.create_subscription(Odometry, "/simplebot_controller/odom", self.odom.append, 10)
        for topic in ("/front_laser/front_scan", "/back_laser/back_scan"):
            self.create_subscription(LaserScan, topic, lambda m: self.scans[m.header.frame_id].append(m),
                                     qos_profile_sensor_data)
        self.create_subscription(DiagnosticStatus, "/simplebot/collisions", self.collisions.append, LATCHED)
        # /rosout is latched (transient local): a warning logged before the endpoints matched still arrives.
        self.create_subscription(Log, "/rosout", self.rosout.append,
                                 QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.tf = Buffer()
        self.listener = TransformListener(self.tf, self)
        self.cmd_vel = self.create_publisher(Twist, "/simplebot_controller/cmd_vel", 10)

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds / 1e9


class Lockstep:
    """Drives a real_time_factor 0 simulator: advance one chunk, then let every message arrive."""

    def __init__(self, context, world):
        self.sim = SimulatorNode(context=context, parameter_overrides=[
            Parameter("world", value=world), Parameter("real_time_factor", value=0.0)])
        self.probe = Probe(context)
        self.executor = SingleThreadedExecutor(context=context)
        for node in (self.sim, self.probe):
            self.executor.add_node(node)
        # Every command that reaches the simulation, in arrival order (NaN ones included).
        self.commands = []
        set_cmd_vel = self.sim.sim.set_cmd_vel

        def spy(v, w, now=None, robot=0):
            self.commands.append((v, w))
            return set_cmd_vel(v, w, now, robot)

        self.sim.sim.set_cmd_vel = spy
        self.pump(lambda: self.probe.collisions and self.sim.count_subscribers("/front_laser/front_scan") >= 1
                  and self.probe.cmd_vel.get_subscription_count() >= 1)

    def pump(self, done, timeout=5.0):
        deadline = time.monotonic() + timeout
        while not done():
            assert time.monotonic() < deadline, "messages did not arrive"
            self.executor.spin_once(timeout_sec=0.01)

    def scans_due(self) -> int:
        return round(self.sim.sim.sim_time / CHUNK + 1e-9)

    def run(self, seconds, cmd=None):
        """Advance `seconds` of sim time; with cmd=(v, w) a controller sends it at 10 Hz."""
        for _ in range(round(seconds / CHUNK)):
            if cmd is not None:
                self.send(*cmd)
            self.sim.advance(CHUNK)
            now = self.sim.sim.sim_time
            self.pump(lambda: self.probe.now_s() == pytest.approx(now)
                      and all(msgs and stamp_s(msgs[-1]) == pytest.approx(now)
                              for msgs in (self.probe.clock, self.probe.odom))
                      and all(len(s) == self.scans_due() for s in self.probe.scans.values()))

    def send(self, v, w):
        count = len(self.commands)
        msg = Twist()
        msg.linear.x, msg.angular.z = v, w
        self.probe.cmd_vel.publish(msg)
        self.pump(lambda: len(self.commands) > count)

    def close(self):
        self.executor.shutdown()
        for node in (self.probe, self.sim):
            node.destroy_node()


@pytest.fixture
def lockstep(context, wall_world):
    stepper = Lockstep(context, wall_world)
    yield stepper
    stepper.close()


def stamp_s(msg) -> float:
    return Time.from_msg(msg.clock if isinstance(msg, Clock) else msg.header.stamp).nanoseconds / 1e9


def status_values(status: DiagnosticStatus) -> dict:
    return {kv.key: kv.value for kv in status.values}


# -- time ----------------------------------------------------------------------------------------

def test_sim_time_nodes_follow_clock(lockstep):
    assert lockstep.probe.now_s() == 0.0
    for _ in range(5):
        lockstep.run(0.1)
        assert lockstep.probe.now_s() == pytest.approx(lockstep.sim.sim.sim_time)
    assert lockstep.probe.now_s() == pytest.approx(0.5)
    stamps = [Time.from_msg(m.clock).nanoseconds for m in lockstep.probe.clock]
    assert stamps == sorted(stamps) and stamps[-1] == 500_000_000


# -- scans ---------------------------------------------------------------------------------------

def test_scans_at_10hz_with_the_lab_lidar_geometry(lockstep):
    lockstep.run(1.0)
    for frame, scans in lockstep.probe.scans.items():
        assert [Time.from_msg(s.header.stamp).nanoseconds for s in scans] == \
            [k * 100_000_000 for k in range(1, 11)], frame
        scan = scans[-1]
        assert scan.header.frame_id == frame
        assert len(scan.ranges) == 683
        assert (scan.angle_min, scan.angle_max) == pytest.approx((-2.0944, 2.0944))
        assert (scan.range_min, scan.range_max) == pytest.approx((0.2, 5.6))
    front = np.array(lockstep.probe.scans["front_laser_link"][-1].ranges)
    assert front[CENTRE] == pytest.approx(WALL_FACE - FRONT_LASER_X, abs=0.01)
    # The wall is 6 m long: the side beams miss it and, with nothing else within 5.6 m, read +inf.
    assert np.isposinf(front[:100]).all() and np.isposinf(front[-100:]).all()
    back = np.array(lockstep.probe.scans["back_laser_link"][-1].ranges)
    assert np.isposinf(back).all()  # nothing behind, and never the robot's own body


# -- transforms and latched topics ---------------------------------------------------------------

def test_tf_static_has_both_lasers(lockstep):
    lockstep.pump(lambda: lockstep.probe.tf.can_transform("base_link", "back_laser_link", Time()))
    front = lockstep.probe.tf.lookup_transform("base_link", "front_laser_link", Time()).transform
    back = lockstep.probe.tf.lookup_transform("base_link", "back_laser_link", Time()).transform
    assert (front.translation.x, front.translation.y, front.translation.z) == pytest.approx((0.35, 0.0, 0.15))
    assert (front.rotation.z, front.rotation.w) == pytest.approx((0.0, 1.0))
    assert (back.translation.x, back.translation.y, back.translation.z) == pytest.approx((-0.35, 0.0, 0.15))
    assert 2 * math.atan2(back.rotation.z, back.rotation.w) == pytest.approx(math.pi)


def test_tf_chains_odom_to_lasers_and_turns_the_wheels(lockstep):
    lockstep.run(2.0, cmd=(0.3, 0.0))
    odom = lockstep.probe.odom[-1].pose.pose.position
    laser = lockstep.probe.tf.lookup_transform("odom", "front_laser_link", Time()).transform.translation
    assert (laser.x, laser.y) == pytest.approx((odom.x + 0.35, odom.y), abs=1e-4)
    for side, y in (("left", 0.23), ("right", -0.23)):
        wheel = lockstep.probe.tf.lookup_transform("base_link", f"{side}_wheel_link", Time()).transform
        assert (wheel.translation.x, wheel.translation.y, wheel.translation.z) == pytest.approx((0.0, y, 0.07))
        angle = 2 * math.atan2(wheel.rotation.y, wheel.rotation.w)  # about the axle (y)
        rolled = odom.x / WHEEL_RADIUS
        assert math.remainder(angle - rolled, 2 * math.pi) == pytest.approx(0.0, abs=0.05)


def test_robot_description_is_latched(lockstep):
    lockstep.run(0.5)
    received = []
    lockstep.probe.create_subscription(String, "/robot_description", received.append, LATCHED)
    lockstep.pump(lambda: received)
    assert received[0].data == BOX.urdf


# -- driving -------------------------------------------------------------------------------------

def test_cmd_vel_0p3_for_5s(lockstep):
    lockstep.run(5.0, cmd=(0.3, 0.0))
    odom = lockstep.probe.odom[-1]
    assert Time.from_msg(odom.header.stamp).nanoseconds == 5_000_000_000
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
    # 0.3 m/s less the acceleration ramp (0.3 / 1.75 m/s^2 at half speed: 2.6 cm).
    assert odom.pose.pose.position.x == pytest.approx(1.47, abs=0.05)
    assert odom.pose.pose.position.y == pytest.approx(0.0, abs=0.01)
    assert odom.twist.twist.linear.x == pytest.approx(0.3, abs=0.005)
    assert status_values(lockstep.probe.collisions[-1])["count"] == "0"


def test_nan_cmd_vel_is_ignored_with_a_warning(lockstep, monkeypatch):
    # Recorded at the node's logger: /rosout is process-global in rclpy and stops once an earlier
    # test of the same process has shut the default context down.
    logger, warnings = lockstep.sim.get_logger(), []
    original = logger.warning

    def record(message, **kwargs):
        warnings.append(message)
        return original(message, **kwargs)

    monkeypatch.setattr(logger, "warning", record)
    monkeypatch.setattr(logger, "warn", record)
    lockstep.run(1.0, cmd=(0.2, 0.0))
    lockstep.send(math.nan, 0.0)
    lockstep.pump(lambda: any("nan" in m for m in warnings))
    assert any("cmd_vel" in m and "nan" in m for m in warnings)
    # The last good command still holds, and the node keeps stepping and publishing.
    lockstep.run(0.3)
    assert lockstep.probe.odom[-1].twist.twist.linear.x == pytest.approx(0.2, abs=0.005)
    lockstep.run(1.0, cmd=(0.2, 0.0))
    assert lockstep.probe.now_s() == pytest.approx(2.3)
    assert lockstep.probe.odom[-1].pose.pose.position.x == pytest.approx(0.2 * 2.3 - 0.011, abs=0.02)


def test_driving_into_the_wall_counts_a_collision(lockstep):
    assert status_values(lockstep.probe.collisions[-1])["count"] == "0"
    lockstep.run(3.0, cmd=(0.8, 0.0))  # contact after about 2.4 s
    report = status_values(lockstep.probe.collisions[-1])
    assert report["count"] == "1" and report["in_contact"] == "True"
    assert lockstep.probe.collisions[-1].level == DiagnosticStatus.WARN
    assert float(report["last_x"]) == pytest.approx(WALL_FACE, abs=0.01)
    assert report["last_obstacle"] == "walls[0]"


# -- real time -----------------------------------------------------------------------------------

def test_real_time_factor_is_honoured(context):
    # An integer, as `--rtf 2` on the command line gives it. The empty world keeps the node's CPU
    # share small, so that the rate it is asked for is what is measured, not the machine's load.
    sim = SimulatorNode(context=context, parameter_overrides=[Parameter("real_time_factor", value=2),
                                                              Parameter("world", value="empty")])
    probe = Node("rtf_probe", context=context)
    samples = []
    probe.create_subscription(Clock, "/clock",
                              lambda m: samples.append((time.monotonic(), Time.from_msg(m.clock).nanoseconds / 1e9)),
                              100)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(sim)
    executor.add_node(probe)
    try:
        start = time.monotonic()
        while time.monotonic() - start < 3.0:
            executor.spin_once(timeout_sec=0.01)
    finally:
        executor.shutdown()
        probe.destroy_node()
        sim.destroy_node()
    # Over the middle two seconds (start-up and the last tick stay out), the median rate of 0.4 s
    # windows: a load spike on a shared machine that stalls the node spoils a few windows only (a window
    # that a stall left with one tick has no rate, and is left out rather than making the median NaN).
    wall, clock = np.array([s for s in samples if start + 0.5 <= s[0] <= start + 2.5]).T
    assert len(wall) > 100
    rates = []
    for t0 in np.arange(wall[0], wall[-1] - 0.4, 0.1):
        i, j = np.searchsorted(wall, [t0, t0 + 0.4])
        if j - i >= 2:
            rates.append((clock[j - 1] - clock[i]) / (wall[j - 1] - wall[i]))
    assert np.median(rates) == pytest.approx(2.0, rel=0.1), np.round(rates, 2)


def test_a_failing_step_ends_the_spin_with_its_error(context):
    # At real time the steps run in their own thread; an error there must not leave a frozen clock.
    sim = SimulatorNode(context=context, parameter_overrides=[Parameter("world", value="empty")])

    def broken_step():
        raise RuntimeError("physics broke")

    sim.sim.step = broken_step
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(sim)
    try:
        with pytest.raises(RuntimeError, match="physics broke"):
            deadline = time.monotonic() + 5.0
            while time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.01)
    finally:
        executor.shutdown()
        sim.destroy_node()


def test_destroying_the_node_stops_its_clock(context):
    sim = SimulatorNode(context=context, parameter_overrides=[Parameter("world", value="empty")])
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(sim)
    try:
        while sim.sim.sim_time < 0.2:
            executor.spin_once(timeout_sec=0.01)
    finally:
        executor.shutdown()
        sim.destroy_node()
    stopped_at = sim.sim.sim_time
    time.sleep(0.1)
    assert sim.sim.sim_time == stopped_at


def test_the_simulator_does_not_follow_its_own_clock(context):
    # It publishes /clock; subscribing to it as well only cost a callback per physics step.
    sim = SimulatorNode(context=context, parameter_overrides=[Parameter("use_sim_time", value=True),
                                                              Parameter("real_time_factor", value=0.0)])
    try:
        assert sim.get_parameter("use_sim_time").value is False
        assert "/clock" not in [s.topic_name for s in sim.subscriptions]
    finally:
        sim.destroy_node()


# -- bad input -----------------------------------------------------------------------------------

@pytest.mark.parametrize("name, value, message", [
    ("world", "atlantis", r"'world'.*'atlantis'.*clutter, doors, empty, lab"),
    ("robot", "tank", r"robot body must be one of box, round; got 'tank'"),
    ("real_time_factor", -1.0, r"'real_time_factor' must be >= 0"),
    ("physics_rate", "fast", r"'physics_rate': expected a number, got 'fast'"),
    ("real_time_factor", float("nan"), r"'real_time_factor': expected a number \(finite\), got nan"),
    ("physics_rate", 0.0, r"'physics_rate': must be > 0, got 0.0"),
    ("odom_scale_std", -0.01, r"parameter 'odom_scale_std' must be >= 0 \(a relative standard deviation\)"),
    ("max_speed", 1.5, r"^parameter 'max_speed': 1.5 m/s is above the box's top speed of 1.05 m/s "),
    ("max_speed", float("nan"), r"^parameter 'max_speed': expected a positive number of m/s, got nan$"),
    ("max_speed", "fast", r"^parameter 'max_speed': expected a positive number of m/s, got 'fast'$"),
])
def test_bad_parameters_fail_with_a_clear_message(context, name, value, message):
    with pytest.raises(ValueError, match=message):
        SimulatorNode(context=context, parameter_overrides=[Parameter(name, value=value)])


@pytest.mark.parametrize("robot, max_speed, top_speed", [("box", "", 1.05), ("round", "", 1.05), ("box", 1, 1.05),
                                                         ("round", 2, 2.0), ("round", 1.5, 2.0)])
def test_max_speed_picks_the_drive(context, robot, max_speed, top_speed):
    """The launcher gives "" when max_speed is not set, and a whole number as an int."""
    sim = SimulatorNode(context=context, parameter_overrides=[
        Parameter("robot", value=robot), Parameter("max_speed", value=max_speed),
        Parameter("real_time_factor", value=0.0)])
    try:
        assert sim.sim.drive == drive_for(sim.description, max_speed or None)
        assert sim.sim.drive.max_wheel_speed * sim.description.wheel_radius == pytest.approx(top_speed)
    finally:
        sim.destroy_node()


@pytest.mark.parametrize("param, message", [
    ("real_time_factor:=0.0", "nothing steps the simulator: run the nodes in one process"),
    ("world:=atlantis", "parameter 'world': unknown world 'atlantis'"),
    ("max_speed:=1.5", "parameter 'max_speed': 1.5 m/s is above the box's top speed of 1.05 m/s"),
])
def test_own_process_refuses_what_it_cannot_run(capfd, param, message):
    assert simulator_main(["simulator", "--ros-args", "-p", param]) == 2
    assert message in capfd.readouterr().err


@pytest.mark.parametrize("name, value", [("real_time_factor", -1.0), ("real_time_factor", math.nan),
                                         ("physics_rate", 0.0), ("world", "doors"), ("seed", 3),
                                         ("max_speed", 2.0), ("use_sim_time", True)])
def test_start_up_parameters_are_refused_while_running_as_requiring_a_restart(lockstep, name, value):
    before = lockstep.sim.get_parameter(name).value
    result = lockstep.sim.set_parameters([Parameter(name, value=value)])[0]
    assert not result.successful and f"{name}: requires restart" in result.reason, result.reason
    assert lockstep.sim.get_parameter(name).value == before


def test_an_unknown_parameter_is_refused_naming_it_and_the_closest_one(lockstep):
    with pytest.raises(ParameterNotDeclaredException, match=r"'real_time_factr' is not a parameter of /simulator "
                                                            r"\(did you mean 'real_time_factor'\?\)"):
        lockstep.sim.set_parameters([Parameter("real_time_factr", value=1.0)])
    assert lockstep.sim.set_parameters([Parameter("faults.tf_delay", value=0.0)])[0].successful
