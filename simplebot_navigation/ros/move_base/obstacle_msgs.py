"""costmap_converter_msgs/ObstacleArrayMsg to and from plain arrays, and the tracks as markers (docs/reference.md §6)."""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from costmap_converter_msgs.msg import ObstacleArrayMsg, ObstacleMsg
from geometry_msgs.msg import Point, Point32, Quaternion
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.perception import Track
# an obstacle another node reports is a person or a robot: one beyond these bounds is dropped
from simplebot_navigation.perception.prediction import MAX_COORDINATE_M, MAX_RADIUS_M, MAX_SPEED_M_S

#: marker height of a tracked obstacle (m)
MARKER_HEIGHT = 1.0
#: caps on another node's ObstacleArrayMsg (docs/reference.md §6.4), checked before its obstacles are read: a
#: message beyond one is refused whole
MAX_OBSTACLES = 100
MAX_POLYGON_POINTS = 100
MAX_POINTS = 1000
MAX_FRAME_ID_BYTES = 256


def obstacle_array_msg(tracks: list[Track], frame: str, stamp: TimeMsg,
                       into: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> ObstacleArrayMsg:
    """Tracks as point obstacles: the centre as a one-point polygon, the radius, the id, the velocity in the
    header frame with its 2x2 covariance in the linear x, y entries. ``into``: the pose of the tracks' frame in
    ``frame`` (positions moved, velocities and covariances turned)."""
    msg = ObstacleArrayMsg()
    msg.header.frame_id, msg.header.stamp = frame, stamp
    turn = np.array([[math.cos(into[2]), -math.sin(into[2])], [math.sin(into[2]), math.cos(into[2])]])
    for track in tracks:
        position = turn @ track.position + into[:2]
        velocity = turn @ track.velocity
        obstacle = ObstacleMsg()
        obstacle.header = msg.header
        obstacle.polygon.points = [Point32(x=float(position[0]), y=float(position[1]))]
        obstacle.radius = float(track.radius)
        obstacle.id = int(track.id)
        heading = math.atan2(velocity[1], velocity[0])
        obstacle.orientation = Quaternion(z=math.sin(heading / 2), w=math.cos(heading / 2))
        obstacle.velocities.twist.linear.x, obstacle.velocities.twist.linear.y = (float(v) for v in velocity)
        covariance = np.zeros((6, 6))
        covariance[:2, :2] = turn @ track.covariance[2:, 2:] @ turn.T
        obstacle.velocities.covariance = covariance.reshape(-1).tolist()
        msg.obstacles.append(obstacle)
    return msg


class RefusedMessage(ValueError):
    """A message beyond one of the caps, or not a well-formed ObstacleArrayMsg: refused whole. ``field`` names
    what was wrong (for throttling the warning by it), the text says the value and the bound."""

    def __init__(self, field: str, text: str):
        super().__init__(f"{field}: {text}")
        self.field = field


@dataclass(frozen=True)
class ObstacleArray:
    """Another node's ObstacleArrayMsg as move_base uses it: rows [x, y, vx, vy, radius] in the message's frame,
    why each dropped obstacle was dropped as (field, text), and the key ObstacleTracking knows its own by."""

    frame: str
    sec: int
    nanosec: int
    ids: tuple
    rows: np.ndarray
    problems: list

    @property
    def key(self) -> tuple:
        return self.sec, self.nanosec, self.frame, self.ids


class _Reader:
    """XCDR1 as every ROS 2 middleware serializes messages: a 4-byte encapsulation header (00 01 little-endian,
    00 00 big-endian), then the fields, each aligned to its size counted from after the header."""

    def __init__(self, raw: bytes):
        if len(raw) < 4 or raw[0] != 0 or raw[1] not in (0, 1):
            raise RefusedMessage("encapsulation", f"{bytes(raw[:4]).hex()} is not plain CDR (0000 or 0001)")
        self.raw, self.order, self.pos = raw, "<" if raw[1] else ">", 4

    def skip(self, size: int, align: int, field: str) -> int:
        """Advance over ``size`` bytes aligned to ``align``; their offset."""
        self.pos += -(self.pos - 4) % align
        start, self.pos = self.pos, self.pos + size
        if self.pos > len(self.raw):
            raise RefusedMessage(field, f"the message ends at byte {len(self.raw)}, inside {field}")
        return start

    def read(self, fmt: str, field: str) -> tuple:
        align = 8 if "d" in fmt or "q" in fmt else 4
        return struct.unpack_from(self.order + fmt, self.raw, self.skip(struct.calcsize("<" + fmt), align, field))

    def string(self, field: str) -> str:
        (length,) = self.read("I", field)
        if length > MAX_FRAME_ID_BYTES + 1:
            raise RefusedMessage(field, f"has {length - 1} bytes, at most {MAX_FRAME_ID_BYTES}")
        start = self.skip(length, 1, field)
        return bytes(self.raw[start:start + max(length - 1, 0)]).decode("utf-8", errors="replace")


def _sizes(reader: _Reader, count: int):
    """Walk the obstacles, checking every length before anything is read: (points offsets and counts, the
    fixed fields after each polygon)."""
    offsets, counts, fixed, total = [], [], [], 0
    for k in range(count):
        reader.read("iI", f"obstacles[{k}].header.stamp")
        reader.string(f"obstacles[{k}].header.frame_id")
        (points,) = reader.read("I", f"obstacles[{k}].polygon.points")
        if points > MAX_POLYGON_POINTS:
            raise RefusedMessage("polygon.points", f"obstacles[{k}].polygon.points has {points} points, at most "
                                 f"{MAX_POLYGON_POINTS}")
        total += points
        if total > MAX_POINTS:
            raise RefusedMessage("points", f"more than {MAX_POINTS} polygon points in all")
        offsets.append(reader.skip(12 * points, 4, f"obstacles[{k}].polygon.points"))
        counts.append(points)
        # radius, id, orientation, velocities.twist (then the covariance, unread)
        fixed.append(reader.read("dq4d6d", f"obstacles[{k}]"))
        reader.skip(36 * 8, 8, f"obstacles[{k}].velocities.covariance")
    return offsets, counts, fixed


def read_obstacle_array(raw: bytes) -> ObstacleArray:
    """A serialized ObstacleArrayMsg, read without building a Python object per obstacle or point, its counts
    checked before the obstacles are read (raises RefusedMessage). A polygon of several points becomes the circle
    around it: its vertices' mean, out to the farthest vertex plus the radius. An obstacle with a point that is
    not finite or beyond MAX_COORDINATE_M, no points, a circle beyond MAX_RADIUS_M or a speed beyond
    MAX_SPEED_M_S is dropped, and why is in ``problems``."""
    reader = _Reader(raw)
    sec, nanosec = reader.read("iI", "header.stamp")
    frame = reader.string("header.frame_id")
    (count,) = reader.read("I", "obstacles")
    if count > MAX_OBSTACLES:
        raise RefusedMessage("obstacles", f"{count} obstacles, at most {MAX_OBSTACLES}")
    offsets, counts, fixed = _sizes(reader, count)
    fixed = np.array(fixed, dtype=float).reshape(-1, 12)
    counts = np.array(counts, dtype=np.int64)
    points = np.concatenate([np.zeros((0, 2))] + [
        np.frombuffer(raw, dtype=reader.order + "f4", count=3 * n, offset=at).reshape(n, 3)[:, :2]
        for at, n in zip(offsets, counts) if n]).astype(float)
    owner = np.repeat(np.arange(count), counts)
    wild = ~(np.abs(points) <= MAX_COORDINATE_M).all(axis=1)              # NaN too
    points[wild] = 0.0
    wild = np.bincount(owner, wild, minlength=count) > 0
    centres = np.stack([np.bincount(owner, points[:, i], minlength=count) for i in (0, 1)], axis=1) \
        / np.maximum(counts, 1)[:, None]
    around = np.zeros(count)
    np.maximum.at(around, owner, np.hypot(*(points - centres[owner]).T))
    radius, velocity = fixed[:, 0], fixed[:, 6:8]
    circle = around + radius
    rows, problems = [], []
    for k in range(count):
        why = _problem(counts[k], wild[k], radius[k], circle[k], velocity[k])
        if why is None:
            rows.append([centres[k, 0], centres[k, 1], velocity[k, 0], velocity[k, 1], circle[k]])
        else:
            problems.append((why[0], f"obstacles[{k}] (id {int(fixed[k, 1])}): {why[1]}"))
    return ObstacleArray(frame, sec, nanosec, tuple(int(i) for i in fixed[:, 1]),
                         np.array(rows, dtype=float).reshape(-1, 5), problems)


def _problem(points: int, wild: bool, radius: float, circle: float, velocity) -> tuple[str, str] | None:
    """(field, why) an obstacle is dropped, or None."""
    if points == 0:
        return "polygon.points", "polygon has no points"
    if wild:
        return "polygon.points", f"polygon.points are not all finite and within {MAX_COORDINATE_M:g} m"
    if not 0.0 <= radius <= MAX_RADIUS_M:
        return "radius", f"radius {radius:g} m is not in [0, {MAX_RADIUS_M:g}] m"
    if not circle <= MAX_RADIUS_M:
        return "radius", f"the circle around the polygon has radius {circle:g} m, at most {MAX_RADIUS_M:g} m"
    speed = math.hypot(*velocity)
    if not speed <= MAX_SPEED_M_S:
        return "velocities", f"velocities.twist.linear ({velocity[0]:g}, {velocity[1]:g}) has speed {speed:g} m/s, " \
                             f"at most {MAX_SPEED_M_S:g} m/s"
    return None


def track_markers(tracks: list[Track], frame: str, stamp: TimeMsg) -> MarkerArray:
    """A cylinder per track (red when moving, grey when not) and an arrow of its velocity; the markers of the
    previous message are deleted first."""
    markers = [Marker(action=Marker.DELETEALL)]
    for track in tracks:
        x, y = (float(v) for v in track.position)
        colour = ColorRGBA(r=1.0, g=0.2, b=0.2, a=0.6) if track.moving else ColorRGBA(r=0.6, g=0.6, b=0.6, a=0.4)
        body = Marker(ns="tracks", id=track.id, type=Marker.CYLINDER, action=Marker.ADD, color=colour)
        body.pose.position = Point(x=x, y=y, z=MARKER_HEIGHT / 2)
        body.pose.orientation.w = 1.0
        body.scale.x = body.scale.y = 2.0 * float(track.radius)
        body.scale.z = MARKER_HEIGHT
        arrow = Marker(ns="velocities", id=track.id, type=Marker.ARROW, action=Marker.ADD, color=colour)
        arrow.points = [Point(x=x, y=y, z=MARKER_HEIGHT), Point(x=x + float(track.velocity[0]),
                                                                  y=y + float(track.velocity[1]), z=MARKER_HEIGHT)]
        arrow.pose.orientation.w = 1.0
        arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.05, 0.1, 0.1
        markers += [body, arrow]
    for marker in markers:
        marker.header.frame_id, marker.header.stamp = frame, stamp
    return MarkerArray(markers=markers)
