"""A goal of the move_base node, from its action server or from /move_base_simple/goal, and the
checks a goal pose must pass before move_base plans to it."""

from __future__ import annotations

import math
import uuid

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from geometry_msgs.msg import PoseStamped
from rclpy.task import Future


class MoveBaseGoal:
    """One goal, from the action server or from /move_base_simple/goal."""

    def __init__(self, pose: PoseStamped, handle=None):
        self.pose = pose
        self.handle = handle
        self.id = str(uuid.UUID(bytes=bytes(handle.goal_id.uuid))) if handle is not None else uuid.uuid4().hex
        self.stamp = pose.header.stamp
        self.done: Future | None = None
        self.status = ActionlibStatus.PENDING
        self.text = ""
        self.finished_wall = None


def validate_goal(pose: PoseStamped) -> str | None:
    """Why a goal cannot be used (move_base's isQuaternionValid plus finite position), or None."""
    p, q = pose.pose.position, pose.pose.orientation
    values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    if not all(math.isfinite(v) for v in values):
        return f"goal has a NaN or inf: position ({p.x}, {p.y}, {p.z}), orientation ({q.x}, {q.y}, {q.z}, {q.w})"
    norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w
    if norm2 < 1e-6:
        return "goal has an invalid quaternion (length close to zero)"
    n = math.sqrt(norm2)
    x, y = q.x / n, q.y / n
    z_axis_z = 1.0 - 2.0 * (x * x + y * y)
    if abs(z_axis_z - 1.0) > 1e-3:
        return "goal orientation is not upright: the quaternion must only rotate about z"
    if not pose.header.frame_id:
        return "goal has an empty frame_id"
    return None

