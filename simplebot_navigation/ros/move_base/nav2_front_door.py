"""Nav2's interfaces on move_base (docs/design.md §7, docs/reference.md §9): the navigation actions,
ComputePathToPose, the behaviours, the costmap services and the lifecycle state that Nav2's clients wait for.

Every navigation goal and behaviour becomes a MoveBaseGoal handed to the GoalArbiter, so one goal is active at a
time whichever interface it came by: a new one preempts the one before (which ends "preempted by a new goal"), as
a MoveBase goal or a /move_base_simple/goal does. A request that cannot be run (a NaN, an unknown frame, too many
poses, a negative distance) is aborted at once with the field in error_msg and leaves the active goal alone.
"""

from __future__ import annotations

import math
import time
from collections import deque

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from geometry_msgs.msg import PoseStamped
from nav2_msgs.action import (BackUp, ComputePathToPose, DriveOnHeading, FollowPath, FollowWaypoints,
                              NavigateThroughPoses, NavigateToPose, Spin, Wait)
from nav2_msgs.msg import MissedWaypoint
from rclpy.task import Future

from simplebot_navigation.move_base.behaviors import (DriveOnHeadingBehavior, SpinBehavior, WaitBehavior, check_drive,
                                                      check_spin, check_time)
from simplebot_navigation.move_base.nav2_requests import (ERROR_CODES, MAX_LOOPS, PASS_RADIUS_M, PLAN_FAILURE_CODES,
                                                          ProgressEstimate, check_pose_count, remaining_distance)
from simplebot_navigation.ros.conversions import duration_msg, duration_s, path_msg, pose_to_xyyaw, xyyaw_to_pose
from simplebot_navigation.ros.move_base.move_base_goal import MoveBaseGoal
from simplebot_navigation.ros.poses import validate_pose

#: the interfaces whose error codes a navigation goal's failure reports (nav2_requests.ERROR_CODES)
_CODE_SOURCES = {"ComputePathToPose": ComputePathToPose, "FollowPath": FollowPath}
#: planner_id values ComputePathToPose takes besides move_base's base_global_planner ("GridBased" is Nav2's
#: default planner name)
PLANNER_IDS = ("", "GridBased")


def navigation_code(cause: str) -> int:
    """The error code of a navigation goal that ended for ``cause`` (0: none)."""
    if cause not in ERROR_CODES:
        return 0
    interface, name = ERROR_CODES[cause]
    return getattr(_CODE_SOURCES[interface].Result, name)


def behavior_code(action, cause: str) -> int:
    """The error code of ``action``'s result for a behaviour's outcome name (UNKNOWN where it has none)."""
    if not cause:
        return 0
    return getattr(action.Result, cause, getattr(action.Result, "UNKNOWN", 0))


def _recoveries(core) -> int:
    return sum(core.events.recoveries.values())


class NavigationFeedback:
    """The feedback fields NavigateToPose and NavigateThroughPoses share, measured each control cycle from the
    state machine ``core``, in ``frame`` (the global costmap's), ``now()`` being node time in seconds."""

    def __init__(self, core, now, frame: str, later: list[tuple[float, float]] = ()):
        self.core, self.now, self.frame = core, now, frame
        self.started = now()
        self.estimate = ProgressEstimate()
        self.recoveries_before = _recoveries(core)
        self.later = list(later)

    def fill(self, msg, pose):
        core = self.core
        now = self.now()
        self.estimate.add(now, pose[0], pose[1])
        msg.current_pose.header.frame_id = self.frame
        msg.current_pose.header.stamp = pose.stamp.to_msg()
        msg.current_pose.pose = xyyaw_to_pose(*pose[:3])
        msg.navigation_time = duration_msg(now - self.started)
        target = core.goal if core.goal is not None else pose[:3]
        distance = remaining_distance(core.plan_remaining(pose[:3]), pose, target, self.later)
        msg.distance_remaining = float(distance)
        msg.estimated_time_remaining = duration_msg(self.estimate.time_remaining(distance))
        msg.number_of_recoveries = min(_recoveries(core) - self.recoveries_before, 2 ** 15 - 1)
        return msg


class Nav2FrontDoor:
    """The execute callbacks of Nav2's actions (``actions``: what the node serves). Each checks its request once and
    hands a goal to the GoalArbiter. It gets: the arbiter; ``check``, the GoalCheck; the state machine ``core``
    (feedback); the global ``planner`` and its type name (ComputePathToPose); the global costmap (its frame and the
    robot's pose for a path from the robot); the node's clock and logger; ``footprint_clear``, the recovery
    context's check the behaviours use; ``period()``, the control period now; and ``behavior_server()``, the
    behaviours' limits now (BehaviorServerParams)."""

    def __init__(self, arbiter, check, core, planner, planner_type: str, global_costmap, clock, logger,
                 footprint_clear, period, behavior_server):
        self.arbiter, self.check, self.core = arbiter, check, core
        self.planner, self.planner_type, self.global_costmap = planner, planner_type, global_costmap
        self._clock, self._logger = clock, logger
        self.footprint_clear, self.period, self.behavior_server = footprint_clear, period, behavior_server
        self._warned_behavior_tree = False
        self.actions = (
            (NavigateToPose, "navigate_to_pose", self._navigate_to_pose),
            (NavigateThroughPoses, "navigate_through_poses", self._navigate_through_poses),
            (FollowWaypoints, "follow_waypoints", self._follow_waypoints),
            (ComputePathToPose, "compute_path_to_pose", self._compute_path_to_pose),
            (Spin, "spin", self._spin),
            (BackUp, "backup", self._backup),
            (DriveOnHeading, "drive_on_heading", self._drive_on_heading),
            (Wait, "wait", self._wait))

    # -- shared ---------------------------------------------------------------------------------------
    def _log(self):
        return self._logger

    def _now(self) -> float:
        return self._clock.now().nanoseconds / 1e9

    def _feedback(self, later=()) -> NavigationFeedback:
        return NavigationFeedback(self.core, self._now, self.global_costmap.global_frame, later)

    def _refuse(self, handle, result, action_name: str, reason: str, code: int = 0):
        self._log().error(f"{action_name}: goal refused: {reason}")
        result.error_code, result.error_msg = code, reason
        handle.abort()
        return result

    def _warn_behavior_tree(self, behavior_tree: str) -> None:
        if behavior_tree and not self._warned_behavior_tree:
            self._warned_behavior_tree = True
            self._log().warn(f"behavior_tree '{behavior_tree[:200]}' has no effect: behaviour trees are not "
                             "supported, move_base's state machine runs every goal")

    async def _drive(self, goal: MoveBaseGoal, target: PoseStamped) -> int:
        """Hand ``goal`` to the arbiter, driven to ``target`` (checked), and wait for its end."""
        goal.done = Future()
        self.arbiter.submit(goal, target)
        return await goal.done

    @staticmethod
    def _end(handle, goal: MoveBaseGoal, result):
        """Finish the action's goal as the MoveBaseGoal ended, the reason and code in the result."""
        if goal.status == ActionlibStatus.SUCCEEDED:
            handle.succeed()
            return result
        result.error_msg = goal.text
        if handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        return result

    # -- navigation -------------------------------------------------------------------------------------
    async def _navigate_to_pose(self, handle):
        request, result = handle.request, NavigateToPose.Result()
        self._warn_behavior_tree(request.behavior_tree)
        target, reason, cause = self.check(request.pose, "pose")
        if reason is not None:
            return self._refuse(handle, result, "navigate_to_pose", reason, navigation_code(cause))
        progress = self._feedback()
        goal = MoveBaseGoal(request.pose, handle, feedback=lambda pose: handle.publish_feedback(
            progress.fill(NavigateToPose.Feedback(), pose)))
        await self._drive(goal, target)
        result.error_code = navigation_code(goal.cause)
        return self._end(handle, goal, result)

    async def _navigate_through_poses(self, handle):
        request, result = handle.request, NavigateThroughPoses.Result()
        self._warn_behavior_tree(request.behavior_tree)
        reason = check_pose_count(len(request.poses))
        if reason is not None:
            return self._refuse(handle, result, "navigate_through_poses", reason, navigation_code("invalid_goal"))
        checked = []
        for i, pose in enumerate(request.poses):
            target, reason, cause = self.check(pose, f"poses[{i}]")
            if reason is not None:
                return self._refuse(handle, result, "navigate_through_poses", reason, navigation_code(cause))
            checked.append(target)
        targets = [pose_to_xyyaw(target.pose) for target in checked]
        remaining = deque(targets[1:])
        progress = self._feedback([t[:2] for t in remaining])

        def advance(pose):
            current = self.core.goal
            if remaining and current is not None and math.hypot(pose[0] - current[0],
                                                                pose[1] - current[1]) <= PASS_RADIUS_M:
                passed = len(targets) - len(remaining)
                self._log().info(f"navigate_through_poses: passed pose {passed} of {len(targets)}")
                following = remaining.popleft()
                progress.later = [t[:2] for t in remaining]
                return following
            return None

        def feedback(pose):
            msg = progress.fill(NavigateThroughPoses.Feedback(), pose)
            msg.number_of_poses_remaining = len(remaining) + 1
            handle.publish_feedback(msg)

        goal = MoveBaseGoal(request.poses[0], handle, feedback=feedback, advance=advance)
        await self._drive(goal, checked[0])
        result.error_code = navigation_code(goal.cause)
        return self._end(handle, goal, result)

    async def _follow_waypoints(self, handle):
        request, result = handle.request, FollowWaypoints.Result()
        poses = request.poses
        reason = check_pose_count(len(poses))
        if reason is None and request.number_of_loops > MAX_LOOPS:
            reason = f"number_of_loops must be at most {MAX_LOOPS}, got {request.number_of_loops}"
        if reason is None and request.goal_index >= len(poses):
            reason = f"goal_index {request.goal_index} is beyond the {len(poses)} poses"
        for i, pose in enumerate(poses):
            reason = reason or validate_pose(pose, f"poses[{i}]")
        if reason is not None:
            return self._refuse(handle, result, "follow_waypoints", reason, FollowWaypoints.Result.UNKNOWN)
        missed = []
        for loop in range(request.number_of_loops + 1):
            for i in range(request.goal_index if loop == 0 else 0, len(poses)):
                handle.publish_feedback(FollowWaypoints.Feedback(current_waypoint=i))
                waypoint = MoveBaseGoal(poses[i], handle)
                waypoint.id = f"{waypoint.id}/{loop}/{i}"
                await self._run_waypoint(waypoint)
                if handle.is_cancel_requested:
                    result.missed_waypoints = missed
                    handle.canceled()
                    return result
                if waypoint.status == ActionlibStatus.PREEMPTED:
                    result.missed_waypoints = missed
                    result.error_msg = f"waypoint {i}: {waypoint.text}"
                    handle.abort()
                    return result
                if waypoint.status != ActionlibStatus.SUCCEEDED:
                    self._log().warn(f"follow_waypoints: waypoint {i} missed: {waypoint.text}")
                    missed.append(MissedWaypoint(index=i, goal=poses[i], error_code=navigation_code(waypoint.cause)))
        result.missed_waypoints = missed
        if missed:
            result.error_msg = f"missed waypoints {', '.join(str(m.index) for m in missed)}"
        handle.succeed()
        return result

    async def _run_waypoint(self, waypoint: MoveBaseGoal) -> None:
        """A waypoint is checked when its turn comes (its frame may move meanwhile): driven, or ended aborted for
        the reason as move_base ends a goal it cannot run."""
        target, reason, cause = self.check(waypoint.pose)
        if reason is None:
            await self._drive(waypoint, target)
            return
        waypoint.done = Future()
        self.arbiter.reject(waypoint, reason, cause)
        await waypoint.done

    def _compute_path_to_pose(self, handle):
        request, result, codes = handle.request, ComputePathToPose.Result(), ComputePathToPose.Result
        planner_ids = PLANNER_IDS + (self.planner_type,)
        if request.planner_id not in planner_ids:
            return self._refuse(handle, result, "compute_path_to_pose",
                                f"planner_id '{request.planner_id}' is not one of {', '.join(map(repr, planner_ids))}",
                                codes.INVALID_PLANNER)
        poses = {}
        for role, pose in (("goal", request.goal), ("start", request.start if request.use_start else None)):
            if pose is None:
                robot = self.global_costmap.get_robot_pose()
                if robot is None:
                    return self._refuse(handle, result, "compute_path_to_pose",
                                        f"no robot pose in {self.global_costmap.global_frame}: "
                                        f"{self.global_costmap.last_pose_error}", codes.TF_ERROR)
                poses[role] = tuple(robot[:3])
                continue
            target, reason, cause = self.check(pose, role)
            if reason is not None:
                code = {"transform": codes.TF_ERROR, "goal_outside_map": codes.START_OUTSIDE_MAP if role == "start"
                        else codes.GOAL_OUTSIDE_MAP}.get(cause, codes.UNKNOWN)
                return self._refuse(handle, result, "compute_path_to_pose", reason, code)
            poses[role] = pose_to_xyyaw(target.pose)
        started = time.perf_counter()
        plan = self.planner.make_plan(poses["start"], poses["goal"])
        result.planning_time = duration_msg(time.perf_counter() - started)
        if not plan.ok:
            result.error_code = getattr(codes, PLAN_FAILURE_CODES[plan.failure.name]) if plan.failure else codes.UNKNOWN
            result.error_msg = plan.message or "the global planner found no path"
            handle.abort()
            return result
        result.path = path_msg(plan.poses, self.global_costmap.global_frame, self._clock.now().to_msg())
        handle.succeed()
        return result

    # -- behaviours ---------------------------------------------------------------------------------
    async def _behave(self, handle, action, behavior, feedback):
        result = action.Result()
        goal = MoveBaseGoal(PoseStamped(), handle, behavior=behavior,
                            feedback=lambda _pose: handle.publish_feedback(feedback(behavior)))
        goal.done = Future()
        started = self._now()
        self.arbiter.submit_behavior(goal)
        await goal.done
        result.total_elapsed_time = duration_msg(self._now() - started)
        result.error_code = behavior_code(action, goal.cause)
        return self._end(handle, goal, result)

    async def _spin(self, handle):
        request = handle.request
        allowance = duration_s(request.time_allowance)
        reason = check_spin(request.target_yaw, allowance)
        if reason is not None:
            return self._refuse(handle, Spin.Result(), "spin", reason, Spin.Result.UNKNOWN)
        behavior = SpinBehavior(request.target_yaw, allowance, self.footprint_clear, self.behavior_server())
        return await self._behave(handle, Spin, behavior,
                                  lambda b: Spin.Feedback(angular_distance_traveled=float(b.progress)))

    async def _drive_along_heading(self, handle, action, name: str, backup: bool):
        request = handle.request
        allowance = duration_s(request.time_allowance)
        target = request.target
        reason = check_drive(target.x, target.y, target.z, request.speed, allowance, backup)
        if reason is not None:
            return self._refuse(handle, action.Result(), name, reason, action.Result.INVALID_INPUT)
        speed = -abs(request.speed) if backup else request.speed
        behavior = DriveOnHeadingBehavior(target.x, speed, allowance, self.footprint_clear, self.period(),
                                          self.behavior_server())
        return await self._behave(handle, action, behavior,
                                  lambda b: action.Feedback(distance_traveled=float(b.progress)))

    async def _backup(self, handle):
        return await self._drive_along_heading(handle, BackUp, "backup", backup=True)

    async def _drive_on_heading(self, handle):
        return await self._drive_along_heading(handle, DriveOnHeading, "drive_on_heading", backup=False)

    async def _wait(self, handle):
        duration = duration_s(handle.request.time)
        reason = check_time(duration, "time")
        if reason is not None:
            return self._refuse(handle, Wait.Result(), "wait", reason)
        return await self._behave(handle, Wait, WaitBehavior(duration),
                                  lambda b: Wait.Feedback(time_left=duration_msg(b.time_left)))
