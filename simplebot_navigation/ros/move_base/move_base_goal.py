"""A goal of the move_base node, from its action server or from /move_base_simple/goal, and the poses of a
make_plan request (move_base's and its global planner's), checked by the rule of ros/poses.py."""

from __future__ import annotations

import math
import uuid

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.srv import GetPlan
from rclpy.task import Future

from simplebot_navigation.ros.conversions import pose_to_xyyaw
from simplebot_navigation.ros.poses import in_frame, validate_pose
from simplebot_navigation.ros.tf import strip_frame


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
