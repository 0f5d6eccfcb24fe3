"""A goal of the move_base node, from its action server or from /move_base_simple/goal, and the
checks a pose must pass before move_base plans to it or from it: one rule for action goals and for
both make_plan services (move_base's and its global planner's)."""

from __future__ import annotations

import math
import uuid

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.srv import GetPlan
from rclpy.task import Future

from simplebot_navigation.ros.conversions import pose_to_xyyaw
from simplebot_navigation.ros.tf import TransformException, strip_frame


class MoveBaseGoal:
    """One goal, from an action server (move_base's or Nav2's) or from /move_base_simple/goal.

    What the control cycle does with it besides driving to ``pose`` comes with it: ``feedback(pose)`` is called
    every cycle with the robot's (x, y, yaw, stamp) in the global frame; ``advance(pose)`` may return the next
    (x, y, yaw) to drive to without stopping (NavigateThroughPoses); a ``behavior`` (behaviors.py) is stepped
    instead of planning and driving to a pose."""

    def __init__(self, pose: PoseStamped, handle=None, feedback=None, advance=None, behavior=None):
        self.pose = pose
        self.handle = handle
        self.feedback = feedback
        self.advance = advance
        self.behavior = behavior
        self.id = str(uuid.UUID(bytes=bytes(handle.goal_id.uuid))) if handle is not None else uuid.uuid4().hex
        self.stamp = pose.header.stamp
        self.done: Future | None = None
        self.status = ActionlibStatus.PENDING
        self.text = ""
        self.cause = ""          # why it was aborted, for Nav2's error codes (nav2_requests.ERROR_CODES)
        self.finished_wall = None


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


def plan_request(request: GetPlan.Request, costmap_ros) -> tuple[tuple, tuple, float | None]:
    """(start, goal, tolerance) of a GetPlan request on a global costmap (``global_frame``, ``tf``,
    ``get_robot_pose()``): the start is request.start if its frame is set, else the robot; each pose passes
    validate_pose and is moved into the global frame; a tolerance of 0 (the request's default) means the
    planner's default_tolerance. ValueError says why a request cannot be planned."""
    frame = strip_frame(costmap_ros.global_frame)
    goal = _planned_pose(request.goal, "goal", frame, costmap_ros.tf)
    if request.start.header.frame_id:
        start = _planned_pose(request.start, "start", frame, costmap_ros.tf)
    else:
        robot = costmap_ros.get_robot_pose()
        if robot is None:
            raise ValueError("the request has no start frame and the robot pose is not available")
        start = tuple(robot[:3])
    tolerance = float(request.tolerance)
    if not (math.isfinite(tolerance) and tolerance >= 0.0):
        raise ValueError(f"tolerance must be finite and >= 0, got {tolerance}")
    return start, goal, tolerance if tolerance > 0.0 else None


def _planned_pose(stamped: PoseStamped, role: str, frame: str, tf) -> tuple[float, float, float]:
    reason = validate_pose(stamped, role)
    target = None
    if reason is None:
        target, reason = in_frame(stamped, frame, tf, role)
    if reason is not None:
        raise ValueError(reason)
    return pose_to_xyyaw(target.pose)
