"""ObstacleArrayMsg as a hostile node could publish them on move_base's obstacles topic (issue 43), serialized, for
tests and bench/probes/move_base.py: a message of 100,000 obstacles is built by repeating one serialized obstacle,
since building 100,000 Python messages would take longer than the probe itself."""

from __future__ import annotations

import math
import struct

from costmap_converter_msgs.msg import ObstacleArrayMsg, ObstacleMsg
from geometry_msgs.msg import Point32
from rclpy.serialization import serialize_message


def obstacle(points, radius: float = 0.0, velocity=(0.0, 0.0), ident: int = 0) -> ObstacleMsg:
    msg = ObstacleMsg(radius=float(radius), id=ident)
    msg.polygon.points = [Point32(x=float(x), y=float(y)) for x, y in points]
    msg.velocities.twist.linear.x, msg.velocities.twist.linear.y = (float(v) for v in velocity)
    return msg


def obstacle_array(obstacles: list[ObstacleMsg], frame: str) -> ObstacleArrayMsg:
    msg = ObstacleArrayMsg(obstacles=obstacles)
    msg.header.frame_id = frame
    return msg


def repeated(one: ObstacleMsg, count: int, frame: str) -> bytes:
    """The serialized ObstacleArrayMsg of ``count`` copies of ``one`` (count >= 2)."""
    empty, two, three = (serialize_message(obstacle_array([one] * n, frame)) for n in (0, 2, 3))
    at = len(empty) - 4                                   # the obstacles' count ends the empty message
    return two[:at] + struct.pack("<I", count) + two[at + 4:] + three[len(two):] * (count - 2)


def hostile_messages(frame: str, x: float, y: float) -> list[tuple[str, bytes]]:
    """(what, serialized message) of every hostile shape, around (x, y) in ``frame``: if move_base took any of
    them, a robot at (x, y) could not drive (or move_base would not keep its rate)."""
    point = obstacle([(x, y)], 0.3)
    polygon = obstacle([(x + 0.5 * math.cos(a / 1592), y + 0.5 * math.sin(a / 1592)) for a in range(10_000)])
    return [
        ("10,000 point obstacles", repeated(point, 10_000, frame)),
        ("100,000 point obstacles", repeated(point, 100_000, frame)),
        ("a polygon of 10,000 points", serialize_message(obstacle_array([polygon], frame))),
        ("10 polygons of 10,000 points", repeated(polygon, 10, frame)),
        ("an obstacle of radius 1e6 m", serialize_message(obstacle_array([obstacle([(x, y)], 1e6)], frame))),
        ("NaN point, radius 1e308, speed 1e308", serialize_message(obstacle_array(
            [obstacle([(math.nan, y)], 0.3), obstacle([(x, y)], 1e308), obstacle([(x, y)], 0.3, (1e308, 0.0))],
            frame))),
    ]
