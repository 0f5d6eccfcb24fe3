"""Nav2's interfaces on move_base (docs/design.md §7, docs/reference.md §9): the navigation actions,
ComputePathToPose, the behaviours, the costmap services and the lifecycle state that Nav2's clients wait for.

Every navigation goal and behaviour becomes a MoveBaseGoal of the node, so one goal is active at a time whichever
interface it came by: a new one preempts the one before (which ends aborted, "preempted by a new goal"), as a
MoveBase goal or a /move_base_simple/goal does. A request that cannot be run (a NaN, an unknown frame, too many
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
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.task import Future

from simplebot_navigation.move_base.behaviors import (DriveOnHeadingBehavior, SpinBehavior, WaitBehavior, check_drive,
                                                      check_spin, check_time)
from simplebot_navigation.move_base.nav2_requests import (ERROR_CODES, MAX_LOOPS, PASS_RADIUS_M, PLAN_FAILURE_CODES,
                                                          ProgressEstimate, check_pose_count, remaining_distance)
from simplebot_navigation.ros.conversions import duration_msg, duration_s, path_msg, pose_to_xyyaw, xyyaw_to_pose
from simplebot_navigation.ros.costmap.costmap_services import CostmapServices
from simplebot_navigation.ros.lifecycle_state import serve_lifecycle_state
from simplebot_navigation.ros.move_base.move_base_goal import MoveBaseGoal
from simplebot_navigation.ros.poses import validate_pose
from simplebot_navigation.ros.qos import SERVICE_QOS

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


class NavigationFeedback:
    """The feedback fields NavigateToPose and NavigateThroughPoses share, measured each control cycle."""

    def __init__(self, node, later: list[tuple[float, float]] = ()):
        self.node = node
        self.started = node.now_s()
        self.estimate = ProgressEstimate()
        self.recoveries_before = node.recoveries
        self.later = list(later)

    def fill(self, msg, pose):
        node = self.node
        now = node.now_s()
        self.estimate.add(now, pose[0], pose[1])
        msg.current_pose.header.frame_id = node.global_costmap.global_frame
        msg.current_pose.header.stamp = pose.stamp.to_msg()
        msg.current_pose.pose = xyyaw_to_pose(*pose[:3])
        msg.navigation_time = duration_msg(now - self.started)
        target = node.core.goal if node.core.goal is not None else pose[:3]
        distance = remaining_distance(node.core.plan_remaining(pose[:3]), pose, target, self.later)
        msg.distance_remaining = float(distance)
        msg.estimated_time_remaining = duration_msg(self.estimate.time_remaining(distance))
        msg.number_of_recoveries = min(node.recoveries - self.recoveries_before, 2 ** 15 - 1)
        return msg


class Nav2FrontDoor:
    def __init__(self, node):
        self.node = node
        self._warned_behavior_tree = False
        group = ReentrantCallbackGroup()
        self.servers = [
            ActionServer(node, action, name, execute_callback=execute, callback_group=group,
                         goal_callback=lambda _request: GoalResponse.ACCEPT,
                         cancel_callback=lambda _handle: CancelResponse.ACCEPT, goal_service_qos_profile=SERVICE_QOS,
                         result_service_qos_profile=SERVICE_QOS, cancel_service_qos_profile=SERVICE_QOS)
            for action, name, execute in (
                (NavigateToPose, "navigate_to_pose", self._navigate_to_pose),
                (NavigateThroughPoses, "navigate_through_poses", self._navigate_through_poses),
                (FollowWaypoints, "follow_waypoints", self._follow_waypoints),
                (ComputePathToPose, "compute_path_to_pose", self._compute_path_to_pose),
                (Spin, "spin", self._spin),
                (BackUp, "backup", self._backup),
                (DriveOnHeading, "drive_on_heading", self._drive_on_heading),
                (Wait, "wait", self._wait))]
        self.costmap_services = [CostmapServices(node, node.global_costmap, "global_costmap"),
                                 CostmapServices(node, node.local_costmap, "local_costmap")]
        serve_lifecycle_state(node, "bt_navigator",
                              lambda: node.global_costmap.initialized and node.local_costmap.initialized)

    # -- shared ---------------------------------------------------------------------------------------
    def _log(self):
        return self.node.get_logger()

    def _refuse(self, handle, result, action_name: str, reason: str, code: int = 0):
        self._log().error(f"{action_name}: goal refused: {reason}")
        result.error_code, result.error_msg = code, reason
        handle.abort()
        return result

    def _check_pose(self, pose: PoseStamped, role: str):
        """(the pose in the global frame, None, "") or (None, why not, the cause)."""
        reason = validate_pose(pose, role)
        if reason is not None:
            return None, reason, "invalid_goal"
        return self.node.goal_in_global_frame(pose, role)

    def _warn_behavior_tree(self, behavior_tree: str) -> None:
        if behavior_tree and not self._warned_behavior_tree:
            self._warned_behavior_tree = True
            self._log().warn(f"behavior_tree '{behavior_tree[:200]}' has no effect: behaviour trees are not "
                             "supported, move_base's state machine runs every goal")

    async def _drive(self, goal: MoveBaseGoal) -> int:
        goal.done = Future()
        self.node._accept_goal(goal)
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
        _, reason, cause = self._check_pose(request.pose, "pose")
        if reason is not None:
            return self._refuse(handle, result, "navigate_to_pose", reason, navigation_code(cause))
        progress = NavigationFeedback(self.node)
        goal = MoveBaseGoal(request.pose, handle, feedback=lambda pose: handle.publish_feedback(
            progress.fill(NavigateToPose.Feedback(), pose)))
        await self._drive(goal)
        result.error_code = navigation_code(goal.cause)
        return self._end(handle, goal, result)

    async def _navigate_through_poses(self, handle):
        request, result = handle.request, NavigateThroughPoses.Result()
        self._warn_behavior_tree(request.behavior_tree)
        reason = check_pose_count(len(request.poses))
        if reason is not None:
            return self._refuse(handle, result, "navigate_through_poses", reason, navigation_code("invalid_goal"))
        targets = []
        for i, pose in enumerate(request.poses):
            target, reason, cause = self._check_pose(pose, f"poses[{i}]")
            if reason is not None:
                return self._refuse(handle, result, "navigate_through_poses", reason, navigation_code(cause))
            targets.append(pose_to_xyyaw(target.pose))
        remaining = deque(targets[1:])
        progress = NavigationFeedback(self.node, [t[:2] for t in remaining])

        def advance(pose):
            current = self.node.core.goal
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
        await self._drive(goal)
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
                await self._drive(waypoint)
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

    def _compute_path_to_pose(self, handle):
        request, result, codes = handle.request, ComputePathToPose.Result(), ComputePathToPose.Result
        node = self.node
        planner_ids = PLANNER_IDS + (node.cfg.base_global_planner,)
        if request.planner_id not in planner_ids:
            return self._refuse(handle, result, "compute_path_to_pose",
                                f"planner_id '{request.planner_id}' is not one of {', '.join(map(repr, planner_ids))}",
                                codes.INVALID_PLANNER)
        poses = {}
        for role, pose in (("goal", request.goal), ("start", request.start if request.use_start else None)):
            if pose is None:
                robot = node.global_costmap.get_robot_pose()
                if robot is None:
                    return self._refuse(handle, result, "compute_path_to_pose",
                                        f"no robot pose in {node.global_costmap.global_frame}: "
                                        f"{node.global_costmap.last_pose_error}", codes.TF_ERROR)
                poses[role] = tuple(robot[:3])
                continue
            target, reason, cause = self._check_pose(pose, role)
            if reason is not None:
                code = {"transform": codes.TF_ERROR, "goal_outside_map": codes.START_OUTSIDE_MAP if role == "start"
                        else codes.GOAL_OUTSIDE_MAP}.get(cause, codes.UNKNOWN)
                return self._refuse(handle, result, "compute_path_to_pose", reason, code)
            poses[role] = pose_to_xyyaw(target.pose)
        started = time.perf_counter()
        plan = node.planner.make_plan(poses["start"], poses["goal"])
        result.planning_time = duration_msg(time.perf_counter() - started)
        if not plan.ok:
            result.error_code = getattr(codes, PLAN_FAILURE_CODES[plan.failure.name]) if plan.failure else codes.UNKNOWN
            result.error_msg = plan.message or "the global planner found no path"
            handle.abort()
            return result
        result.path = path_msg(plan.poses, node.global_costmap.global_frame, node.get_clock().now().to_msg())
        handle.succeed()
        return result

    # -- behaviours ---------------------------------------------------------------------------------
    async def _behave(self, handle, action, behavior, feedback):
        result = action.Result()
        goal = MoveBaseGoal(PoseStamped(), handle, behavior=behavior,
                            feedback=lambda _pose: handle.publish_feedback(feedback(behavior)))
        goal.done = Future()
        started = self.node.now_s()
        self.node.start_behavior(goal)
        await goal.done
        result.total_elapsed_time = duration_msg(self.node.now_s() - started)
        result.error_code = behavior_code(action, goal.cause)
        return self._end(handle, goal, result)

    async def _spin(self, handle):
        request = handle.request
        allowance = duration_s(request.time_allowance)
        reason = check_spin(request.target_yaw, allowance)
        if reason is not None:
            return self._refuse(handle, Spin.Result(), "spin", reason, Spin.Result.UNKNOWN)
        behavior = SpinBehavior(request.target_yaw, allowance, self.node.recovery_context.footprint_clear,
                                self.node.behavior_server)
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
        behavior = DriveOnHeadingBehavior(target.x, speed, allowance, self.node.recovery_context.footprint_clear,
                                          self.node.period, self.node.behavior_server)
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
