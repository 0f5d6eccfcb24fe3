"""The collision monitor's probes (issue 43), against the live launch's /collision_monitor.

Each hostile parameter that used to switch the monitor off without a trace is set live, then the robot is driven
at 0.3 m/s on /cmd_vel_nav at the wall ahead of it for long enough to hit it: it must stop short, with no new
collision. Then ±1 and ±100 m/s alternating at 1 kHz on /cmd_vel_nav for 3 s must barely move the robot, a teleop
on /cmd_vel_teleop must hold the output over the planner and be guarded like it, and a publisher on the base's
input must be named in the monitor's log, and another node's tracks on move_base's topic must not make the wall
ahead walk away. The robot is left standing, the monitor the process it was.
"""

from __future__ import annotations

import math
import time

from bench.probes._common import set_parameter

NODE = "/collision_monitor"
TWO_CM = "[[0.01, 0.01], [0.01, -0.01], [-0.01, -0.01], [-0.01, 0.01]]"
HOSTILE = [("enabled", False), ("footprint", TWO_CM), ("min_points", 1000), ("time_before_collision", 0.0),
           ("stop_distance", 0.0), ("slowdown_distance", 0.0)]
#: the defaults the launch gives, to put back whatever was accepted
DEFAULTS = {"enabled": True, "min_points": 3, "time_before_collision": 0.5, "stop_distance": 0.02,
            "slowdown_distance": 0.1}
SPEED = 0.3
#: long enough to reach the wall from where backing off left the robot, and then some
AT_WALL_S = 8.0
BACK_OFF_S = 3.5
#: the robot stands when it moves less than this in a second (m)
STANDING = 0.02


def twist(v: float, w: float = 0.0):
    from geometry_msgs.msg import Twist

    msg = Twist()
    msg.linear.x, msg.angular.z = float(v), float(w)
    return msg


def moved(a, b) -> float:
    return math.hypot(b.x - a.x, b.y - a.y)


def drive(session, sources: list[tuple], seconds: float, rate: float = 20.0) -> tuple[float, float]:
    """Publish each (publisher, v, w) or (publisher, message) at ``rate`` for wall seconds: (metres driven, metres in the last second)."""
    start, period, next_at = session.pose(), 1.0 / rate, [0.0]
    began = time.monotonic()

    def send() -> bool:
        now = time.monotonic()
        if now >= next_at[0]:
            for publisher, *what in sources:        # (publisher, v, w), or (publisher, message)
                publisher.publish(twist(*what) if len(what) == 2 else what[0])
            next_at[0] = now + period
        return False

    session.spin_wall(max(seconds - 1.0, 0.0), send)
    before_last = session.pose()
    session.spin_wall(seconds - (time.monotonic() - began), send)
    end = session.pose()
    return moved(start, end), moved(before_last, end)


def stand(session, nav) -> None:
    drive(session, [(nav, 0.0, 0.0)], 1.0)


def at_the_wall(session, nav, client) -> list[tuple[str, str, str, bool]]:
    """Each hostile parameter, then 0.3 m/s at the wall: refused, or at least no collision."""
    rows = []
    for _ in range(15):                          # to the wall ahead first (bench/probe.py leaves it there)
        if drive(session, [(nav, 1.0, 0.0)], 2.0)[1] < STANDING:
            break
    for name, value in HOSTILE:
        drive(session, [(nav, -SPEED, 0.0)], BACK_OFF_S)               # room to hit the wall again
        ok, reason = set_parameter(session, client, name, value)
        collisions = session.client.collisions
        driven, last = drive(session, [(nav, SPEED, 0.0)], AT_WALL_S)
        new = session.client.collisions - collisions
        if ok and name in DEFAULTS:
            set_parameter(session, client, name, DEFAULTS[name])
        rows.append((f"{NODE} {name} live, then {SPEED} m/s at a wall", repr(value)[:46],
                     f"{'accepted' if ok else 'refused: ' + reason[:70]}; drove {driven:.2f} m, {last:.3f} m in "
                     f"the last second, {new} collisions", not ok and new == 0 and last < STANDING))
    return rows


def flood(session, nav) -> tuple[str, str, str, bool]:
    """±1, ±100 m/s alternating at 1 kHz for 3 s: the output is ramped, clamped and thinned."""
    drive(session, [(nav, -SPEED, 0.0)], BACK_OFF_S)
    stand(session, nav)
    collisions, start = session.client.collisions, session.pose()
    values, sent, began = (1.0, -1.0, 100.0, -100.0), [0], time.monotonic()

    def burst() -> bool:
        due = int((time.monotonic() - began) * 1000.0)
        while sent[0] < due:
            nav.publish(twist(values[sent[0] % 4]))
            sent[0] += 1
        return False

    session.spin_wall(3.0, burst)
    stand(session, nav)
    distance, new = moved(start, session.pose()), session.client.collisions - collisions
    return ("cmd_vel_nav flood for 3 s", f"±1, ±100 m/s alternating, {sent[0]} messages",
            f"moved {distance:.3f} m, {new} collisions", distance < 0.1 and new == 0)


def teleop(session, nav, keys) -> list[tuple[str, str, str, bool]]:
    """cmd_vel_teleop holds the output over cmd_vel_nav while it speaks, and is guarded like it."""
    rows = []
    held, _ = drive(session, [(nav, -SPEED, 0.0), (keys, 0.0, 0.0)], 2.0)
    rows.append(("teleop priority: zero on cmd_vel_teleop", f"and {-SPEED} m/s on cmd_vel_nav, 2 s",
                 f"moved {held:.3f} m", held < STANDING))
    drive(session, [(nav, -SPEED, 0.0)], 1.0)                          # the teleop's timeout, then the planner
    released, _ = drive(session, [(nav, -SPEED, 0.0)], 2.0)
    rows.append(("teleop silent: cmd_vel_nav again", f"{-SPEED} m/s on cmd_vel_nav, 2 s",
                 f"moved {released:.3f} m", released > 0.2))
    collisions = session.client.collisions
    driven, last = drive(session, [(keys, SPEED, 0.0)], AT_WALL_S)
    new = session.client.collisions - collisions
    rows.append(("teleop guarded: cmd_vel_teleop at a wall", f"{SPEED} m/s for {AT_WALL_S:g} s",
                 f"drove {driven:.2f} m, {last:.3f} m in the last second, {new} collisions",
                 new == 0 and last < STANDING))
    return rows


def bypass(session) -> tuple[str, str, str, bool]:
    """A second publisher on the base's input is named in the monitor's log."""
    from geometry_msgs.msg import Twist

    publisher = session.client.create_publisher(Twist, "/simplebot_controller/cmd_vel", 1)
    name = session.client.get_fully_qualified_name()
    needle = f"{name} publishes on /simplebot_controller/cmd_vel"
    found = session.spin_wall(10.0, lambda: needle in session.log_text())
    session.client.destroy_publisher(publisher)
    return ("teleop on simplebot_controller/cmd_vel", f"a publisher from {name}",
            "named in the monitor's log" if found else "no warning within 10 s", found)


def rogue_tracks(session, nav) -> tuple[str, str, str, bool]:
    """Another node's tracks on move_base's topic, claiming the wall ahead walks away at 10 m/s: not believed
    (docs/reference.md §5.1), so 0.3 m/s at the wall still stops short of it."""
    from costmap_converter_msgs.msg import ObstacleArrayMsg, ObstacleMsg
    from geometry_msgs.msg import Point32

    msg = ObstacleArrayMsg()
    msg.header.frame_id = "base_link"                 # wherever the robot is: the wall ahead
    obstacle = ObstacleMsg()
    obstacle.polygon.points = [Point32(x=0.9, y=0.0)]
    obstacle.radius, obstacle.velocities.twist.linear.x = 0.9, 10.0
    msg.obstacles = [obstacle]
    tracks = session.client.create_publisher(ObstacleArrayMsg, "/move_base/obstacle_tracks/robot_frame", 10)
    drive(session, [(nav, -SPEED, 0.0)], BACK_OFF_S)
    collisions = session.client.collisions
    try:
        driven, last = drive(session, [(nav, SPEED, 0.0), (tracks, msg)], AT_WALL_S)
    finally:
        session.client.destroy_publisher(tracks)
    new = session.client.collisions - collisions
    return ("rogue obstacle_tracks/robot_frame, then 0.3 m/s at a wall", "the wall walking away at 10 m/s",
            f"drove {driven:.2f} m, {last:.3f} m in the last second, {new} collisions",
            new == 0 and last < STANDING)


def run(session) -> list[tuple[str, str, str, bool]]:
    from geometry_msgs.msg import Twist
    from rclpy.parameter_client import AsyncParameterClient

    pid = session.node_pid("collision_monitor")
    client = AsyncParameterClient(session.client, NODE)
    nav = session.client.create_publisher(Twist, "/cmd_vel_nav", 1)
    keys = session.client.create_publisher(Twist, "/cmd_vel_teleop", 1)
    try:
        rows = at_the_wall(session, nav, client)
        rows.append(flood(session, nav))
        rows.extend(teleop(session, keys=keys, nav=nav))
        rows.append(bypass(session))
        rows.append(rogue_tracks(session, nav))
    finally:
        stand(session, nav)
        session.client.destroy_publisher(nav)
        session.client.destroy_publisher(keys)
    same = session.node_pid("collision_monitor") == pid
    rows.append(("collision_monitor afterwards", f"pid {pid}", "same process" if same else "restarted", same))
    return rows
