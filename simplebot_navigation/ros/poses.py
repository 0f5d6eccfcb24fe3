"""The checks a requested pose must pass before anything plans to it, from it or around it, and putting it in
a frame: one rule for move_base's goals, both make_plan services, Nav2's actions and the costmaps' clearing
services."""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseStamped

from simplebot_navigation.ros.tf import TransformException, strip_frame


def validate_pose(pose: PoseStamped, role: str = "goal") -> str | None:
    """Why a pose cannot be planned to or from (move_base's isQuaternionValid plus a finite position and
    a frame), or None; ``role`` names it in the reason."""
    p, q = pose.pose.position, pose.pose.orientation
    values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    if not all(math.isfinite(v) for v in values):
        return f"{role} has a NaN or inf: position ({p.x}, {p.y}, {p.z}), orientation ({q.x}, {q.y}, {q.z}, {q.w})"
    norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w
    if norm2 < 1e-6:
        return f"{role} has an invalid quaternion (length close to zero)"
    n = math.sqrt(norm2)
    x, y = q.x / n, q.y / n
    z_axis_z = 1.0 - 2.0 * (x * x + y * y)
    if abs(z_axis_z - 1.0) > 1e-3:
        return f"{role} orientation is not upright: the quaternion must only rotate about z"
    if not pose.header.frame_id:
        return f"{role} has an empty frame_id"
    return None


def in_frame(pose: PoseStamped, frame: str, tf, role: str = "goal") -> tuple[PoseStamped | None, str | None]:
    """``pose`` in ``frame`` by the latest transform of the buffer ``tf``, or None and why not."""
    if strip_frame(pose.header.frame_id) == frame:
        target = PoseStamped()
        target.header.frame_id = frame
        target.header.stamp = pose.header.stamp
        target.pose = pose.pose
        return target, None
    try:
        return tf.transform_pose(pose, frame, latest=True), None
    except TransformException as err:
        return None, f"cannot transform the {role} from {pose.header.frame_id} to {frame}: {err}"
