"""A goal of the move_base node, from its action server or from /move_base_simple/goal, the check every front door
gives a requested pose once (GoalCheck), and the poses of a make_plan request (move_base's and its global
planner's), checked by the rule of ros/poses.py."""

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
        self.pose = pose          # as requested, in the requester's frame
        self.handle = handle
        self.feedback = feedback
        self.advance = advance
        self.behavior = behavior
        self.behavior_started = False   # a behaviour starts in the first control cycle that has the robot's pose
        self.id = str(uuid.UUID(bytes=bytes(handle.goal_id.uuid))) if handle is not None else uuid.uuid4().hex
        self.stamp = pose.header.stamp
        self.done: Future | None = None
        self.status = ActionlibStatus.PENDING
        self.text = ""
        self.cause = ""          # why it was aborted, for Nav2's error codes (nav2_requests.ERROR_CODES)
        self.finished_wall = None


class GoalCheck:
    """The one check of a requested pose: valid (validate_pose), moved into the global costmap's frame by the
    latest transform, and inside that costmap. Each front door runs it once per pose and hands the result on."""

    def __init__(self, global_costmap):
        self._costmap_ros = global_costmap

    @property
    def frame(self) -> str:
        return self._costmap_ros.global_frame

    def __call__(self, pose: PoseStamped, role: str = "goal") -> tuple[PoseStamped | None, str | None, str]:
        """(the pose in the global frame, None, "") or (None, why not, the cause: "invalid_goal", "transform" or
        "goal_outside_map", for Nav2's error codes)."""
        reason = validate_pose(pose, role)
        if reason is not None:
            return None, reason, "invalid_goal"
        frame = self.frame
        target, reason = in_frame(pose, frame, self._costmap_ros.tf, role)
        if target is None:
            return None, reason, "transform"
        x, y = target.pose.position.x, target.pose.position.y
        master = self._costmap_ros.costmap
        if master.world_to_map(x, y) is None:
            x1 = master.origin_x + master.size_x * master.resolution
            y1 = master.origin_y + master.size_y * master.resolution
            return None, (f"{role} ({x:.6g}, {y:.6g}) is outside the global costmap "
                          f"[{master.origin_x:.2f}, {x1:.2f}] x [{master.origin_y:.2f}, {y1:.2f}] in {frame}"), \
                "goal_outside_map"
        return target, None, ""


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
