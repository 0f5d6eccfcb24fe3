"""costmap_converter_msgs/ObstacleArrayMsg to and from plain arrays, and the tracks as markers (docs/reference.md §6)."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from costmap_converter_msgs.msg import ObstacleArrayMsg, ObstacleMsg
from geometry_msgs.msg import Point, Point32, Quaternion
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.perception import Track

#: marker height of a tracked obstacle (m)
MARKER_HEIGHT = 1.0


def obstacle_array_msg(tracks: list[Track], frame: str, stamp: TimeMsg) -> ObstacleArrayMsg:
    """Tracks as point obstacles: the centre as a one-point polygon, the radius, the id, the velocity in the
    header frame with its 2x2 covariance in the linear x, y entries."""
    msg = ObstacleArrayMsg()
    msg.header.frame_id, msg.header.stamp = frame, stamp
    for track in tracks:
        obstacle = ObstacleMsg()
        obstacle.header = msg.header
        obstacle.polygon.points = [Point32(x=float(track.position[0]), y=float(track.position[1]))]
        obstacle.radius = float(track.radius)
        obstacle.id = int(track.id)
        heading = math.atan2(track.velocity[1], track.velocity[0])
        obstacle.orientation = Quaternion(z=math.sin(heading / 2), w=math.cos(heading / 2))
        obstacle.velocities.twist.linear.x, obstacle.velocities.twist.linear.y = (float(v) for v in track.velocity)
        covariance = np.zeros((6, 6))
        covariance[:2, :2] = track.covariance[2:, 2:]
        obstacle.velocities.covariance = covariance.reshape(-1).tolist()
        msg.obstacles.append(obstacle)
    return msg


def obstacle_rows(msg: ObstacleArrayMsg) -> tuple[np.ndarray, list[str]]:
    """Rows [x, y, vx, vy, radius] in the message's frame, and why each dropped obstacle was dropped (naming the
    field). A polygon of several points becomes the circle around it: its vertices' mean, out to the farthest
    vertex plus the radius."""
    rows, problems = [], []
    for k, obstacle in enumerate(msg.obstacles):
        points = np.array([(p.x, p.y) for p in obstacle.polygon.points], dtype=float).reshape(-1, 2)
        velocity = (obstacle.velocities.twist.linear.x, obstacle.velocities.twist.linear.y)
        where = f"obstacles[{k}] (id {obstacle.id})"
        if not len(points):
            problems.append(f"{where}: polygon has no points")
        elif not np.isfinite(points).all():
            problems.append(f"{where}: polygon.points are not all finite")
        elif not (math.isfinite(obstacle.radius) and obstacle.radius >= 0):
            problems.append(f"{where}: radius must be finite and >= 0, got {obstacle.radius}")
        elif not all(math.isfinite(v) for v in velocity):
            problems.append(f"{where}: velocities.twist.linear is not finite: {velocity}")
        else:
            centre = points.mean(axis=0)
            around = float(np.hypot(*(points - centre).T).max())
            rows.append([centre[0], centre[1], velocity[0], velocity[1], around + obstacle.radius])
    return np.array(rows, dtype=float).reshape(-1, 5), problems


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
