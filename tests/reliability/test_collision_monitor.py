"""The collision monitor as a node between a hostile command source and the simulated base, in lockstep.

A publisher that knows nothing of the world drives the robot at a wall at 1 m/s: with the monitor the
robot stops short of it, for both bodies, forward and in reverse; without it, it hits the wall.
"""

import dataclasses
import math
import time

import numpy as np
import pytest
from costmap_converter_msgs.msg import ObstacleArrayMsg, ObstacleMsg
from geometry_msgs.msg import Point32, TransformStamped, Twist
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from simplebot_navigation.ros.collision_monitor_node import CollisionMonitorNode
from simplebot_navigation.safety.collision_monitor import CollisionMonitor
from simplebot_navigation.ros.simulator.lockstep import LockstepDriver
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from tests.conftest import fresh_context

SIM_TIME = [Parameter("use_sim_time", value=True)]
BOX = "[[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]"
WALL_X = 4.0          # the face of the wall the robot is driven at
WORLD = f"""name: wall_ahead
walls:
  - {{from: [{WALL_X + 0.1}, -3.0], to: [{WALL_X + 0.1}, 3.0], thickness: 0.2, height: 1.0}}
boxes: []
cylinders: []
start: {{x: 0.0, y: 0.0, yaw: 0.0}}
goals: []
"""


@pytest.fixture
def context():
    yield from fresh_context()


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    path = tmp_path_factory.mktemp("worlds") / "wall_ahead.yaml"
    path.write_text(WORLD)
    return str(path)


class CommandSource(Node):
    """Publishes (v, w) at 20 Hz of sim time on ``topic`` until told to stop; records what the base is sent."""

    def __init__(self, context, topic: str, v: float, w: float = 0.0, namespace: str = "", name="command_source"):
        super().__init__(name, namespace=namespace, context=context, parameter_overrides=SIM_TIME)
        self.command = (v, w)
        self.sending = True
        self.pub = self.create_publisher(Twist, topic, 1)
        self.sent_to_base: list[tuple[float, float, float]] = []    # (sim time, v, w)
        self.create_subscription(Twist, "simplebot_controller/cmd_vel", self._on_base, 10)
        self.create_timer(0.05, self._send)

    def _send(self):
        if self.sending:
            msg = Twist()
            msg.linear.x, msg.angular.z = (float(x) for x in self.command)
            self.pub.publish(msg)

    def _on_base(self, msg):
        self.sent_to_base.append((self.get_clock().now().nanoseconds * 1e-9, msg.linear.x, msg.angular.z))


def start(context, world, robot="box", yaw=0.0, namespace="", monitor=True, v=1.0, max_speed=None, others=(),
          **monitor_params):
    drive = [] if max_speed is None else [Parameter("max_speed", value=float(max_speed))]
    if max_speed is not None:                       # as the launch files give it
        monitor_params.setdefault("max_linear_speed", float(max_speed))
    sim = SimulatorNode(context=context, parameter_overrides=SIM_TIME + drive + [
        Parameter("world", value=world), Parameter("robot", value=robot), Parameter("real_time_factor", value=0.0),
        Parameter("namespaces", value=namespace), Parameter("starts", value=f"0,0,{yaw}")])
    nodes = []
    if monitor:
        body = {"footprint": BOX} if robot == "box" else {"robot_radius": 0.3}
        if namespace:
            body["base_frame"] = f"{namespace}/base_link"
        body["scan_silence_timeout"] = 0.0           # lockstep: wall time means nothing
        nodes.append(CollisionMonitorNode(context=context, namespace=namespace, parameter_overrides=SIM_TIME + [
            Parameter(k, value=val) for k, val in {**body, **monitor_params}.items()]))
    source = CommandSource(context, "cmd_vel_nav" if monitor else "simplebot_controller/cmd_vel", v,
                           namespace=namespace)
    driver = LockstepDriver(sim, [*nodes, source, *(make(context) for make in others)])
    return sim, nodes, source, driver


def wall_gap(sim: SimulatorNode, robot: str) -> float:
    """How far the body is from the wall's face (the robot faces or backs towards it along x)."""
    return WALL_X - sim.sim.ground_truth().x - (0.45 if robot == "box" else 0.3)


@pytest.mark.parametrize("robot, reverse, namespace", [("box", False, ""), ("round", False, ""),
                                                       ("box", True, "robot1"), ("round", True, "")])
def test_a_command_at_1_m_s_into_a_wall_stops_short_of_it(context, world, robot, reverse, namespace):
    sim, _, source, driver = start(context, world, robot, yaw=math.pi if reverse else 0.0, namespace=namespace,
                                   v=-1.0 if reverse else 1.0)
    driver.run_until(12.0)
    gap = wall_gap(sim, robot)
    assert sim.sim.collisions(0).count == 0
    assert 0.0 < gap < 0.5, f"stopped {gap:.2f} m from the wall"
    assert abs(sim.sim.ground_truth().x) > 2.5          # it did drive, and fast
    assert max(abs(v) for _, v, _ in source.sent_to_base) > 0.9
    assert abs(source.sent_to_base[-1][1]) < 0.01        # and is held still in front of the wall
    driver.executor.shutdown()


def test_a_command_at_2_m_s_into_a_wall_stops_short_of_it_with_the_jackal_drive(context, world):
    # The approach check's 0.5 s horizon is 1 m at 2 m/s: the drive's 0.8 m to stop at 2.5 m/s^2 (0.4 s) and a
    # command period's travel (0.1 m) fit in it (docs/reference.md §5.1).
    sim, _, source, driver = start(context, world, "round", v=2.0, max_speed=2.0)
    peak = []
    driver.on_step(lambda: peak.append(sim.sim.ground_truth().vx))
    driver.run_until(8.0)
    gap = wall_gap(sim, "round")
    assert max(peak) == pytest.approx(2.0, abs=0.01)                 # at full speed before the horizon
    assert sim.sim.collisions(0).count == 0
    assert 0.0 < gap < 0.5, f"stopped {gap:.2f} m from the wall"
    assert abs(source.sent_to_base[-1][1]) < 0.01
    driver.executor.shutdown()


def test_without_the_monitor_the_same_command_hits_the_wall(context, world):
    sim, _, _, driver = start(context, world, "box", monitor=False)
    driver.run_until(12.0)
    assert sim.sim.collisions(0).count > 0
    driver.executor.shutdown()


def test_a_silent_command_source_gets_zero_within_the_source_timeout(context, world):
    _, _, source, driver = start(context, world, "round", v=0.5)
    driver.run_until(1.0)
    source.sending = False
    stopped_at = driver.time
    driver.run_until(stopped_at + 0.5)
    after = [(t, v) for t, v, _ in source.sent_to_base if t > stopped_at]
    zero = next(t for t, v in after if v == 0.0)
    assert zero - stopped_at <= 0.3 + 0.1 + 0.01    # source_timeout, and the next scan (10 Hz)
    driver.executor.shutdown()


def test_stale_scans_stop_the_robot(context, world):
    sim, _, source, driver = start(context, world, "round", v=0.5)
    driver.run_until(1.0)
    sim.set_parameters([Parameter("faults.scan_dropout", value="front_laser_link")])
    driver.run_until(2.0)
    assert source.sent_to_base[-1][1] == 0.0
    sim.set_parameters([Parameter("faults.scan_dropout", value="")])
    driver.run_until(2.5)
    assert source.sent_to_base[-1][1] == pytest.approx(0.5)
    driver.executor.shutdown()


@pytest.mark.parametrize("v, w", [(math.nan, 0.0), (1e308, 0.0), (0.3, -math.inf)])
def test_a_hostile_command_becomes_zero(context, world, v, w):
    _, _, source, driver = start(context, world, "round", v=0.5)
    driver.run_until(1.0)
    source.command = (v, w)
    driver.run_until(1.2)
    assert source.sent_to_base[-1][1:] == (0.0, 0.0)
    source.command = (0.5, 0.0)
    driver.run_until(1.6)                                          # speeding up from zero at 1.75 m/s^2
    assert source.sent_to_base[-1][1] == pytest.approx(0.5)       # the node is still there and working
    driver.executor.shutdown()


def test_live_parameters_are_checked_in_full(context, world, capfd):
    _, (monitor,), _, driver = start(context, world, "box", v=0.0)

    def refused(name, value):
        try:
            result = monitor.set_parameters([Parameter(name, value=value)])[0]
        except ParameterNotDeclaredException as err:    # a set_parameters service call answers with this text
            return str(err)
        return None if result.successful else result.reason

    assert "out of range" in refused("stop_distance", -1.0)
    assert "out of range" in refused("slowdown_ratio", math.nan)
    assert "expected an integer" in refused("min_points", "many")
    assert "at least three points" in refused("footprint", "[[0, 0], [1, 1]]")
    assert "slowdown_distance" in refused("stop_distance", 0.5)                # above the slowdown zone's 0.1
    assert "requires restart" in refused("cmd_vel_out_topic", "/elsewhere")
    assert "did you mean 'stop_distance'" in refused("stop_distanse", 0.1)
    assert refused("time_before_collision", 0.8) is None
    assert monitor.monitor.config.time_before_collision == 0.8
    assert monitor.monitor.config.stop_distance == 0.02                          # the refusals changed nothing
    assert refused("footprint", "[[0.5, 0.35], [0.5, -0.35], [-0.5, -0.35], [-0.5, 0.35]]") is None   # it may grow
    log = capfd.readouterr().err
    assert "parameter time_before_collision changed live: 0.5 -> 0.8" in log       # at WARN, old and new
    assert "parameter footprint changed live" in log
    assert "parameter change refused: collision_monitor parameter 'min_points': expected an integer" in log
    driver.executor.shutdown()


TWO_CM = "[[0.01, 0.01], [0.01, -0.01], [-0.01, -0.01], [-0.01, 0.01]]"


@pytest.mark.parametrize("hostile", [{"enabled": False}, {"footprint": TWO_CM}, {"min_points": 1000},
                                     {"time_before_collision": 0.0},
                                     {"stop_distance": 0.0, "slowdown_distance": 0.0}])
def test_no_live_parameter_lets_a_command_drive_the_robot_into_a_wall(context, world, hostile):
    """Issue 43: each of these, set live with no trace, switched the monitor off; 0.3 m/s then hit the wall."""
    sim, (monitor,), source, driver = start(context, world, "box", v=0.3)
    driver.run_until(0.5)
    results = [monitor.set_parameters([Parameter(name, value=value)])[0] for name, value in hostile.items()]
    assert [(r.successful, bool(r.reason)) for r in results] == [(False, True)] * len(hostile)
    driver.run_until(16.0)                       # 3.55 m to the wall at 0.3 m/s
    assert sim.sim.collisions(0).count == 0
    assert 0.0 < wall_gap(sim, "box") < 0.3 and abs(source.sent_to_base[-1][1]) < 0.01
    driver.executor.shutdown()


def test_a_teleop_holds_the_output_over_the_planner_while_it_speaks(context, world):
    """twist_mux's rule: cmd_vel_teleop's commands win while fresher than teleop_timeout (0.5 s)."""
    teleop = []
    _, _, source, driver = start(context, world, "round", v=0.3, others=[lambda c: teleop.append(
        CommandSource(c, "cmd_vel_teleop", -0.2, name="teleop")) or teleop[0]])
    teleop[0].sending = False
    driver.run_until(1.5)
    assert source.sent_to_base[-1][1] == pytest.approx(0.3)
    teleop[0].sending = True
    driver.run_until(3.0)
    held = [v for t, v, _ in source.sent_to_base if 2.0 < t <= 3.0]
    assert held and all(v == pytest.approx(-0.2) for v in held)        # the planner's 0.3 does not get through
    teleop[0].sending = False
    driver.run_until(4.5)
    assert source.sent_to_base[-1][1] == pytest.approx(0.3)            # the planner's again
    driver.executor.shutdown()


def test_another_publisher_on_the_base_input_is_named_in_a_warning(context, world, capfd):
    """A teleop on simplebot_controller/cmd_vel bypasses the monitor: the user is told which node it is."""
    rogue = []

    def keyboard(c):
        rogue.append(Node("teleop_twist_keyboard", context=c, parameter_overrides=SIM_TIME))
        rogue[0].create_publisher(Twist, "simplebot_controller/cmd_vel", 1)
        return rogue[0]

    _, _, _, driver = start(context, world, "round", v=0.0, others=[keyboard])
    driver.run_until(1.0)
    assert "/teleop_twist_keyboard publishes on /simplebot_controller/cmd_vel: its commands bypass the " \
           "collision monitor; publish them on /cmd_vel_teleop instead" in capfd.readouterr().err
    driver.executor.shutdown()


def scan_message(frame: str, stamp: float, distance: float = 3.0) -> LaserScan:
    msg = LaserScan()
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(stamp), int(round((stamp % 1) * 1e9))
    msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max = -2.0, 4.0 / 100, 0.2, 5.6
    msg.ranges = [distance] * 101
    return msg


@pytest.fixture
def bare_monitor(context):
    """A monitor fed by direct calls, its output recorded: what it does with time."""
    monitor = CollisionMonitorNode(context=context, parameter_overrides=[   # a drive that reaches 0.4 m/s at once
        Parameter("robot_radius", value=0.3), Parameter("scan_silence_timeout", value=0.2),
        Parameter("max_linear_accel", value=10.0), Parameter("use_sim_time", value=True)])
    sent = []
    monitor.cmd_pub.publish = lambda twist: sent.append(twist.linear.x)
    transforms = []
    for frame, x in (("front_laser_link", 0.2), ("back_laser_link", -0.2)):
        tf = TransformStamped()
        tf.header.frame_id, tf.child_frame_id = "base_link", frame
        tf.transform.translation.x, tf.transform.rotation.w = x, 1.0
        transforms.append(tf)
    monitor._on_tf_static(TFMessage(transforms=transforms))

    def scans(stamp: float) -> None:
        for source, frame in zip(monitor.sources, ("front_laser_link", "back_laser_link")):
            monitor._on_scan(source, scan_message(frame, stamp))

    def command(v: float) -> float:
        twist = Twist()
        twist.linear.x = v
        monitor._on_command(twist, teleop=False)
        return sent[-1]

    yield monitor, scans, command
    monitor.destroy_node()


def test_it_keeps_time_by_its_scans_not_by_clock(bare_monitor):
    monitor, scans, command = bare_monitor
    assert not monitor.get_parameter("use_sim_time").value     # no /clock subscription, and its cost
    scans(5.0)
    assert command(0.4) == pytest.approx(0.4)
    scans(5.1)
    scans(5.2)
    scans(5.35)                                  # 0.35 s of scan time without a command: the planner is gone
    assert monitor._out == (0.0, 0.0)


def test_commands_while_every_lidar_is_silent_are_stopped_by_wall_time(bare_monitor):
    _, scans, command = bare_monitor
    scans(5.0)
    assert command(0.4) == pytest.approx(0.4)
    time.sleep(0.3)                              # scan_silence_timeout 0.2 s of wall time
    assert command(0.4) == 0.0
    scans(5.1)
    assert command(0.4) == pytest.approx(0.4)


def test_a_flood_of_alternating_commands_is_clamped_ramped_and_thinned(bare_monitor):
    """Issue 43: ±1 and ±100 m/s alternating at 1 kHz on cmd_vel_nav for 3 s were forwarded at 437 messages a
    second and drove the robot 2.95 m backwards. Now: within the drive's top speed, speeding up at its
    acceleration (so the alternation cancels within millimetres) and at most max_output_rate (50 Hz) a second."""
    monitor, scans, command = bare_monitor
    monitor.monitor = CollisionMonitor(dataclasses.replace(monitor.monitor.config, max_linear_accel=0.0))   # 1.75
    out, published = [], []
    monitor.cmd_pub.publish = lambda twist: published.append(twist.linear.x)
    for ms in range(3000):                        # the scans at 10 Hz, the flood at 1 kHz (1 ms apart)
        if ms % 100 == 0:
            scans(5.0 + ms / 1000)
        twist = Twist()
        twist.linear.x = (1.0, -1.0, 100.0, -100.0)[ms % 4]
        monitor._on_command(twist, teleop=False)
        out.append(monitor._out[0])
    assert max(abs(v) for v in out) <= 1.05
    assert abs(sum(out) * 0.001) < 0.05           # metres, had the robot followed every output for 1 ms
    assert len(published) <= 3 * 50 + 20


def test_time_going_back_starts_every_source_again(bare_monitor):
    monitor, scans, command = bare_monitor
    scans(100.0)
    monitor._on_scan(monitor.sources[0], scan_message("front_laser_link", 2.0))   # a restarted simulation
    assert command(0.4) == 0.0                   # the back lidar has not spoken on the new timeline
    scans(2.1)
    assert command(0.4) == pytest.approx(0.4)


def person_scan(frame: str, stamp: float, centre: float, radius: float = 0.25) -> LaserScan:
    """A scan of scan_message's geometry from a laser with a person (a circle ``centre`` m ahead of it)."""
    msg = scan_message(frame, stamp)
    angles = msg.angle_min + msg.angle_increment * np.arange(len(msg.ranges))
    reach = radius ** 2 - (centre * np.sin(angles)) ** 2
    hit = (reach >= 0) & (np.cos(angles) > 0)
    msg.ranges = np.where(hit, centre * np.cos(angles) - np.sqrt(np.maximum(reach, 0.0)), 3.0).tolist()
    return msg


def tracks_message(stamp: float, rows, frame: str = "base_link") -> bytes:
    """An ObstacleArrayMsg of (x, y, radius, vx, vy) rows, serialized as the subscription takes it."""
    msg = ObstacleArrayMsg()
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(stamp), int(round((stamp % 1) * 1e9))
    for x, y, radius, vx, vy in rows:
        obstacle = ObstacleMsg()
        obstacle.polygon.points = [Point32(x=float(x), y=float(y))]
        obstacle.radius = float(radius)
        obstacle.velocities.twist.linear.x, obstacle.velocities.twist.linear.y = float(vx), float(vy)
        msg.obstacles.append(obstacle)
    return serialize_message(msg)


def test_a_person_walking_away_on_the_tracks_topic_does_not_stop_the_robot(bare_monitor, capfd):
    """The person's returns 1.5 cm ahead of the face: standing, they stop a command; tracked walking away at
    1 m/s (move_base's obstacle_tracks/robot_frame), they do not. Stale, too wide, malformed tracks, or tracks in
    a frame not fixed to the robot, leave the returns standing."""
    monitor, _, command = bare_monitor

    def scans(stamp: float) -> None:
        monitor._on_scan(monitor.sources[0], person_scan("front_laser_link", stamp, 0.3 + 0.015 + 0.25 - 0.2))
        monitor._on_scan(monitor.sources[1], scan_message("back_laser_link", stamp))

    scans(5.0)
    assert command(0.4) == 0.0
    monitor._on_tracks(tracks_message(5.0, [(0.565, 0.0, 0.25, 1.0, 0.0)]))
    scans(5.05)                                  # (a new scan: the drive's ramp counts scan time)
    assert command(0.4) == pytest.approx(0.4)
    monitor._on_tracks(b"\x00\x01\x00\x00" + b"\xff" * 12)                   # malformed: refused, kept
    assert "obstacle_tracks/robot_frame: message of 16 bytes refused" in capfd.readouterr().err
    scans(5.1)
    assert command(0.4) == pytest.approx(0.4)
    monitor._on_tracks(tracks_message(5.1, [(0.565, 0.0, 2.0, 1.0, 0.0)]))     # a wall, not a person
    scans(5.15)
    assert command(0.4) == 0.0
    monitor._on_tracks(tracks_message(5.15, [(0.565, 0.0, 0.25, 1.0, 0.0)], frame="odom"))
    scans(5.2)
    assert command(0.4) == 0.0
    assert "tracks in 'odom', not in a frame fixed to base_link" in capfd.readouterr().err
    monitor._on_tracks(tracks_message(4.0, [(0.565, 0.0, 0.25, 1.0, 0.0)]))    # as of a second ago
    scans(5.25)
    assert command(0.4) == 0.0
    assert "the last tracks are 1.25 s old: every return is judged standing" in capfd.readouterr().err


def test_tracks_are_not_believed_while_another_node_publishes_them(bare_monitor, context, capfd):
    """A node that is not move_base could make a wall walk away: while one publishes on the tracks topic, every
    return stands."""
    monitor, _, command = bare_monitor
    rogue = Node("rogue_tracker", context=context)
    rogue.create_publisher(ObstacleArrayMsg, "/move_base/obstacle_tracks/robot_frame", 1)
    for stamp in (5.0, 5.05):
        monitor._on_scan(monitor.sources[0], person_scan("front_laser_link", stamp, 0.3 + 0.015 + 0.25 - 0.2))
        monitor._on_scan(monitor.sources[1], scan_message("back_laser_link", stamp))
        monitor._on_tracks(tracks_message(stamp, [(0.565, 0.0, 0.25, 1.0, 0.0)]))
        monitor._check_publishers()
    assert command(0.4) == 0.0
    assert "/rogue_tracker publish(es) on /move_base/obstacle_tracks/robot_frame: the tracks are not believed" \
        in capfd.readouterr().err
    rogue.destroy_node()
    monitor._check_publishers()
    monitor._on_scan(monitor.sources[0], person_scan("front_laser_link", 5.1, 0.3 + 0.015 + 0.25 - 0.2))
    monitor._on_scan(monitor.sources[1], scan_message("back_laser_link", 5.1))
    monitor._on_tracks(tracks_message(5.1, [(0.565, 0.0, 0.25, 1.0, 0.0)]))
    assert command(0.4) == pytest.approx(0.4)
