"""collision_monitor: the last word on every velocity command, in its own process (docs/reference.md §5).

It takes the planner's commands on ``cmd_vel_nav``, a teleop's on ``cmd_vel_teleop`` (which, as in twist_mux,
hold the output while they are fresher than ``teleop_timeout``) and the raw scans, and publishes what may reach
the wheels on ``simplebot_controller/cmd_vel`` (all relative, so they follow the namespace): within the drive's
top speeds and accelerations, at a bounded rate. Its only transforms are the lasers' static ones; move_base's
tracks in the robot's frame say which returns move. It cannot
be switched off, nor its body shrunk, while it runs; every accepted live change is logged at WARN.

Its clock is its scans' stamps (the newest seen): simulated time under a simulator, wall time on a robot,
without following /clock, whose 100 messages a second alone cost a Python node more than the monitor's
whole budget. A stopped planner or a stale lidar is measured in the time the robot moves in; a frozen
simulator freezes the world too. When every lidar falls silent while commands still come, wall time
decides (``scan_silence_timeout``).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time

import numpy as np
from costmap_converter_msgs.msg import ObstacleArrayMsg
from geometry_msgs.msg import Twist
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from simplebot_navigation.geometry import quaternion_to_rotation_matrix, transform_points
from simplebot_navigation.parameters.spec import Param, ParameterError
from simplebot_navigation.ros.conversions import transform_to_xyyaw
from simplebot_navigation.ros.move_base.obstacle_msgs import RefusedMessage, read_obstacle_array
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import descriptor, refuse_unknown_parameters
from simplebot_navigation.ros.publishers import create_publisher, drop_event_handlers_of_best_effort_subscriptions
from simplebot_navigation.ros.tf import TF_STATIC_LISTENER_QOS, Buffer, TransformException, strip_frame
from simplebot_navigation.safety.collision_monitor import (PARAMETERS, Action, CollisionMonitor,
                                                           CollisionMonitorConfig, moved_by, track_velocities)
from simplebot_navigation.safety.command_limits import Ramp, RateLimit, brakes, clamp

#: read at start-up only: the topics, the frame the scans are turned into, the wall-clock guard
AT_START = {
    "base_frame": Param(str, "base_link", "", "the robot frame the body is given in", dynamic=False),
    "cmd_vel_in_topic": Param(str, "cmd_vel_nav", "", "the planner's commands", dynamic=False),
    "cmd_vel_teleop_topic": Param(str, "cmd_vel_teleop", "", "a teleop's commands: guarded as the planner's, "
                                  "they hold the output while fresher than teleop_timeout", dynamic=False),
    "cmd_vel_out_topic": Param(str, "simplebot_controller/cmd_vel", "", "the base's commands", dynamic=False),
    "scan_topics": Param(list, ["front_laser/front_scan", "back_laser/back_scan"], "",
                         "the LaserScan topics to watch (at most 8)", dynamic=False),
    "obstacle_tracks_topic": Param(str, "move_base/obstacle_tracks/robot_frame", "", "move_base's moving tracks "
                                   "in the robot's frame: their returns are judged as moving (empty: every "
                                   "return stands still)",
                                   dynamic=False),
    "scan_silence_timeout": Param(float, 1.0, "s", "wall time without any scan, while commands come, that stops "
                                  "the robot (0: off, as in lockstep, where wall time means nothing)",
                                  low=0.0, high=60.0, dynamic=False),
}
MAX_SCAN_TOPICS = 8
#: a command faster than this is not a command (m/s and rad/s)
MAX_COMMAND = 100.0
#: a scan stamped this much before the newest one means time went back (a restarted simulation)
TIME_JUMP_BACK_S = 1.0
#: one line per kind of trouble (a source's scans, the commands, a zone) this often at most
LOG_PERIOD_S = 2.0


@dataclasses.dataclass
class _Source:
    topic: str
    points: np.ndarray | None = None    # robot frame, as the scan saw them
    stamp: float = -math.inf            # its stamp, seconds (the node's sensor time)
    sensor: dict = dataclasses.field(default_factory=dict)   # frame_id -> (2, 3), from /tf_static


class CollisionMonitorNode(SetUpNode):
    def __init__(self, **kwargs):
        super().__init__("collision_monitor", **kwargs)

    def _set_up(self) -> None:
        values = {}
        for name, spec in {**PARAMETERS, **AT_START}.items():
            default = spec.default if name != "footprint" else ""   # ROS 2 has no empty-list type
            given = self.declare_parameter(name, default, descriptor(spec)).value
            values[name] = spec.check(given, f"collision_monitor parameter '{name}'")
        topics = values.pop("scan_topics")
        if not 1 <= len(topics) <= MAX_SCAN_TOPICS or not all(isinstance(t, str) and t for t in topics):
            raise ValueError(f"collision_monitor parameter 'scan_topics': 1 to {MAX_SCAN_TOPICS} topic names, "
                             f"got {topics!r}")
        self.base_frame = values.pop("base_frame").lstrip("/")
        self.scan_silence_timeout = values.pop("scan_silence_timeout")
        cmd_in, cmd_out = values.pop("cmd_vel_in_topic"), values.pop("cmd_vel_out_topic")
        teleop = values.pop("cmd_vel_teleop_topic")
        tracks_topic = values.pop("obstacle_tracks_topic")
        self.monitor = CollisionMonitor(CollisionMonitorConfig(**values))
        self.body = self.monitor          # the body it started with: a live footprint must hold it
        if not self.monitor.config.enabled:
            self.get_logger().warn("enabled is false: commands pass unjudged (the drive's limits and the timeouts "
                                   "still apply); it cannot be switched on or off while running")
        self.tf = Buffer(node=self)
        self._now = -math.inf              # sensor time: the newest scan stamp, seconds
        self._last_scan_wall = time.monotonic()
        self._last_command = None          # sensor time of the last command received
        self._out = (0.0, 0.0)             # the last command published
        self._ramp, self._rate = Ramp(), RateLimit()
        self._teleop_at = -math.inf        # sensor time of the last teleop command
        self._holder = ""                  # the input the last command passed came from
        self._bypass: set[str] = set()     # other publishers on the output, warned about once
        self._state = ""                   # what the last verdict was, to log changes only
        self._logged: dict[str, float] = {}  # kind -> monotonic time of its last line
        self.sources = [_Source(topic) for topic in topics]
        self.cmd_pub = create_publisher(self, Twist, cmd_out, 1)
        self.create_subscription(TFMessage, "/tf_static", self._on_tf_static, TF_STATIC_LISTENER_QOS)
        self._tracks = None                # (frame, stamp, rows [x, y, vx, vy, radius]) of the last message
        self._tracks_topic = self.resolve_topic_name(tracks_topic) if tracks_topic else ""
        self._tracks_trusted = True        # no node but move_base publishes them (_check_publishers)
        if tracks_topic:
            self.create_subscription(ObstacleArrayMsg, tracks_topic, self._on_tracks, QoSProfile(depth=1), raw=True)
        for source in self.sources:
            self.create_subscription(LaserScan, source.topic, lambda msg, s=source: self._on_scan(s, msg),
                                     qos_profile_sensor_data)
        self._topics = {False: self.resolve_topic_name(cmd_in), True: self.resolve_topic_name(teleop)}
        self.create_subscription(Twist, cmd_in, lambda msg: self._on_command(msg, teleop=False), 1)
        self.create_subscription(Twist, teleop, lambda msg: self._on_command(msg, teleop=True), 1)
        if self.get_parameter("use_sim_time").value:
            self.set_parameters([Parameter("use_sim_time", value=False)])   # drops the /clock subscription
            self.get_logger().info("use_sim_time is not used: the scans' stamps are this node's clock")
        drop_event_handlers_of_best_effort_subscriptions(self)     # the scans: every wake walks them
        refuse_unknown_parameters(self)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._cmd_out = self.resolve_topic_name(cmd_out)
        self.get_logger().info(f"{self._topics[False]} (and {self._topics[True]} over it) -> {self._cmd_out}, "
                               f"watching {', '.join(self.resolve_topic_name(t) for t in topics)}")

    # -- parameters -----------------------------------------------------------------------------
    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Every change checked in full before it is taken (the body must hold the one the node started with);
        the new judgement replaces the old one whole. Each change is logged at WARN with both values, each
        refusal with its reason."""
        try:
            monitor = self._changed(params)
        except Exception as err:   # noqa: BLE001 -- any failure of a check is a refusal with its reason
            self._warn("parameters", f"parameter change refused: {err}")
            return SetParametersResult(successful=False, reason=str(err))
        old = self.monitor.config
        for name in (p.name for p in params):
            if getattr(old, name) != getattr(monitor.config, name):
                self.get_logger().warn(f"parameter {name} changed live: {getattr(old, name)!r} -> "
                                       f"{getattr(monitor.config, name)!r}")
        self.monitor = monitor
        return SetParametersResult(successful=True)

    def _changed(self, params: list[Parameter]) -> CollisionMonitor:
        """The judgement with ``params``, or ParameterError."""
        specs = {**PARAMETERS, **AT_START}
        fixed = [p.name for p in params if p.name == "use_sim_time" or not specs[p.name].dynamic]
        if fixed:
            raise ParameterError(f"{', '.join(fixed)}: requires restart (the monitor's switch, topics and drive "
                                 "limits do not change while it runs)")
        changes = {p.name: PARAMETERS[p.name].check(p.value, f"collision_monitor parameter '{p.name}'")
                   for p in params}
        monitor = CollisionMonitor(dataclasses.replace(self.monitor.config, **changes))
        if not monitor.holds(self.body):
            started = self.body.config.footprint or f"radius {self.body.radius:g} m"
            raise ParameterError("collision_monitor footprint/robot_radius: the body must hold the robot's, as "
                                 f"the node started with ({started})")
        return monitor

    # -- inputs ---------------------------------------------------------------------------------
    def _on_tf_static(self, msg: TFMessage) -> None:
        for tf in msg.transforms:
            try:
                self.tf.set_transform_static(tf, "/tf_static")
            except Exception as err:   # noqa: BLE001 -- a hostile transform is dropped, with its reason
                self._warn("tf_static", f"/tf_static: transform dropped: {err}")
        for source in self.sources:
            source.sensor.clear()     # looked up again with what is known now

    def _on_tracks(self, raw: bytes) -> None:
        """move_base's moving tracks; refused whole (with the reason) when beyond the caps or malformed."""
        try:
            msg = read_obstacle_array(raw)
        except RefusedMessage as refused:
            self._warn("tracks", f"{self._tracks_topic}: message of {len(raw)} bytes refused: {refused}")
            return
        for _field, problem in msg.problems:
            self._warn("tracked obstacle", f"{self._tracks_topic}: obstacle dropped: {problem}")
        self._tracks = (strip_frame(msg.frame), msg.sec + msg.nanosec * 1e-9, msg.rows)

    def _tracks_now(self, now: float) -> np.ndarray:
        """(M, 5) the tracks at ``now`` in the robot frame: x, y, radius, vx, vy; none when they are older (or
        newer) than source_timeout or not in a frame fixed to the robot, and then every return stands still.
        Like the scans' points, they are moved on by what the robot was told to do since their stamp."""
        if self._tracks is None or not len(self._tracks[2]) or not self._tracks_trusted:
            return np.empty((0, 5))
        frame, stamp, rows = self._tracks
        age = now - stamp
        if not abs(age) <= self.monitor.config.source_timeout:
            self._warn("stale tracks", f"{self._tracks_topic}: the last tracks are {age:.2f} s old: every return "
                                       "is judged standing")
            return np.empty((0, 5))
        try:       # the robot's frame, or one the static transforms fix to it
            placed = transform_to_xyyaw(self.tf.lookup_transform(self.base_frame, frame, Time()))
        except (TransformException, ValueError) as err:
            self._warn("tracks frame", f"{self._tracks_topic}: tracks in '{frame}', not in a frame fixed to "
                                       f"{self.base_frame} ({err}): every return is judged standing")
            return np.empty((0, 5))
        centres = transform_points(placed, rows[:, :2] + age * rows[:, 2:4])
        velocities = transform_points((0.0, 0.0, placed[2]), rows[:, 2:4])
        if age > 0:
            centres = moved_by(centres, *self._out, age)
            velocities = moved_by(velocities, 0.0, self._out[1], age)      # turned only
        return np.column_stack([centres, rows[:, 4], velocities])

    def _sensor(self, source: _Source, frame: str) -> np.ndarray | None:
        """The laser's (2, 3) map into the robot frame, from the static transforms."""
        if frame not in source.sensor:
            try:
                tf = self.tf.lookup_transform(self.base_frame, frame, Time())
            except TransformException as err:
                self._warn(source.topic, f"{source.topic}: no static transform {self.base_frame} <- '{frame}' "
                                         f"yet ({err}); the scan is not used")
                return None
            q, t = tf.transform.rotation, tf.transform.translation
            rotation = quaternion_to_rotation_matrix(q.x, q.y, q.z, q.w)
            source.sensor[frame] = np.column_stack([rotation[:2, :2], [t.x, t.y]])
        return source.sensor[frame]

    def _on_scan(self, source: _Source, msg: LaserScan) -> None:
        if msg.header.stamp.sec < 0:
            self._warn(source.topic, f"{source.topic}: scan dropped: negative stamp {msg.header.stamp.sec} s")
            return
        stamp = Time.from_msg(msg.header.stamp).nanoseconds * 1e-9
        sensor = self._sensor(source, msg.header.frame_id.lstrip("/"))
        if sensor is None:
            return
        try:
            points = self.monitor.scan_points(msg.ranges, msg.angle_min, msg.angle_increment, msg.range_min,
                                              msg.range_max, sensor)
        except ValueError as err:
            self._warn(source.topic, f"{source.topic}: scan dropped: {err}")
            return
        if stamp < self._now - TIME_JUMP_BACK_S:    # a restarted simulation, or the scan before was hostile
            self._warn("time", f"{source.topic}: time went back from {self._now:.2f} s to {stamp:.2f} s: "
                               "every source starts again")
            for other in self.sources:
                other.points, other.stamp = None, -math.inf
            self._last_command, self._now = None, stamp
            self._teleop_at = -math.inf
            self._ramp.restart(stamp)
        self._now = max(self._now, stamp)
        self._last_scan_wall = time.monotonic()
        source.points, source.stamp = points, stamp
        self._check_silence()
        if self._due("publishers"):
            self._check_publishers()

    def _on_command(self, msg: Twist, teleop: bool) -> None:
        """A command from the planner or (teleop) the teleop; the teleop's hold the output while fresh."""
        now = self._now
        if teleop:
            self._teleop_at = now
        elif now - self._teleop_at <= self.monitor.config.teleop_timeout:
            return
        if self._holder != self._topics[teleop]:
            self._holder = self._topics[teleop]
            self.get_logger().info(f"commands from {self._holder}")
        v, w = msg.linear.x, msg.angular.z
        if not (math.isfinite(v) and math.isfinite(w) and abs(v) <= MAX_COMMAND and abs(w) <= MAX_COMMAND):
            self._warn("command", f"{self._holder}: command (linear.x {v!r}, angular.z {w!r}) is not a velocity: "
                                  "zero published")
            self._publish(0.0, 0.0, "stop: the last command was not a velocity")
            return
        config = self.monitor.config
        v, w = clamp(v, w, config.max_linear_speed, config.max_angular_speed)
        v, w = self._ramp.limit((v, w), now, (config.linear_accel(), config.max_angular_accel))
        self._last_command = now
        silent = time.monotonic() - self._last_scan_wall
        if 0 < self.scan_silence_timeout < silent:
            self._publish(0.0, 0.0, f"stop: no scan for {silent:.1f} s (wall time)")
            return
        points, stale = self._points_now(now)
        if stale:
            self._publish(0.0, 0.0, f"stop: {stale}")
            return
        tracks = self._tracks_now(now)
        verdict = self.monitor.limit(v, w, points, track_velocities(points, tracks) if len(tracks) else None)
        self._publish(verdict.v, verdict.w, "" if verdict.action is Action.PASS else
                      f"{verdict.action.value}: {verdict.why}")

    def _points_now(self, now: float) -> tuple[np.ndarray, str]:
        """Every source's points, moved by what the robot was told to do since the scan; or why it cannot be."""
        timeout = self.monitor.config.source_timeout
        clouds = []
        for source in self.sources:
            age = now - source.stamp
            if source.points is None:
                return np.empty((0, 2)), f"no scan on {source.topic} yet"
            if not -timeout <= age <= timeout:
                return np.empty((0, 2)), f"the last scan on {source.topic} is {age:.2f} s old"
            clouds.append(moved_by(source.points, *self._out, max(age, 0.0)) if age > 0 else source.points)
        return np.concatenate(clouds), ""

    def _check_silence(self) -> None:
        """No command for source_timeout: the planner stopped or died. Zero, for stop_pub_timeout (checked at
        every scan, twice per 0.1 s with two lidars)."""
        if self._last_command is None:
            return
        config = self.monitor.config
        silent = self._now - self._last_command
        if config.source_timeout < silent <= config.source_timeout + config.stop_pub_timeout:
            self._publish(0.0, 0.0, f"stop: no command for {config.source_timeout:g} s")

    # -- output ---------------------------------------------------------------------------------
    def _publish(self, v: float, w: float, state: str) -> None:
        """(v, w), within the drive's accelerations (_on_command), at most at max_output_rate unless it brakes or
        stands: the rate counts the scans' time, which stops with the scans, and the robot must go on being told
        to stand (move_base's watchdog repeats its zero)."""
        config, now = self.monitor.config, self._now
        standing = v == 0.0 and w == 0.0
        if not self._rate.allow(now, config.max_output_rate, braking=standing or brakes(self._out, (v, w))):
            self._warn("rate", f"commands come faster than max_output_rate {config.max_output_rate:g} Hz: the "
                               "excess is not published")
            if not any(new * old < 0 for new, old in zip((v, w), self._out)):
                return
            v, w = 0.0, 0.0              # a reversal that has to wait: the robot stands meanwhile (braking goes)
            self._rate.allow(now, config.max_output_rate, braking=True)
        twist = Twist()
        twist.linear.x, twist.angular.z = float(v), float(w)
        self.cmd_pub.publish(twist)
        self._out = (float(v), float(w))
        self._ramp.published(self._out, now)
        kind, was = state.partition(":")[0], self._state.partition(":")[0]
        if kind and kind != was:
            self._warn(kind, f"{state}: {self._cmd_out} limited to ({v:.2f} m/s, {w:.2f} rad/s)")
        elif was and not kind and self._due(""):
            self.get_logger().info(f"{was} cleared: commands pass")
        self._state = state

    def _check_publishers(self) -> None:
        """Warn once about each other node publishing on the base's input: its commands bypass the monitor. The
        tracks are believed only while move_base (of this namespace) alone publishes them: another node's
        velocities could make a wall walk away."""
        for info in self.get_publishers_info_by_topic(self._cmd_out):
            name = f"{info.node_namespace.rstrip('/')}/{info.node_name}"
            if name != self.get_fully_qualified_name() and name not in self._bypass:
                self._bypass.add(name)
                self.get_logger().warn(f"{name} publishes on {self._cmd_out}: its commands bypass the collision "
                                       f"monitor; publish them on {self._topics[True]} instead")
        if self._tracks_topic:
            move_base = f"{self.get_namespace().rstrip('/')}/move_base"
            others = sorted({f"{i.node_namespace.rstrip('/')}/{i.node_name}"
                             for i in self.get_publishers_info_by_topic(self._tracks_topic)} - {move_base})
            if others and self._tracks_trusted:
                self.get_logger().warn(f"{', '.join(others)} publish(es) on {self._tracks_topic}: the tracks are "
                                       f"not believed (every return is judged standing) while any node but "
                                       f"{move_base} does")
            elif not others and not self._tracks_trusted:
                self.get_logger().info(f"only {move_base} publishes on {self._tracks_topic}: its tracks are believed")
            self._tracks_trusted = not others

    def _due(self, kind: str) -> bool:
        now = time.monotonic()
        if now - self._logged.get(kind, -math.inf) < LOG_PERIOD_S:
            return False
        self._logged[kind] = now
        return True

    def _warn(self, kind: str, text: str) -> None:
        if self._due(kind):
            self.get_logger().warn(text)


def main(args=None) -> int:
    return run_node("collision_monitor", CollisionMonitorNode, args)


if __name__ == "__main__":
    sys.exit(main())
