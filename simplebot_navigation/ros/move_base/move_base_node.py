"""The move_base node: costmaps, planner and controller plugins, the state machine, and its interfaces.

A thin shell: MoveBaseCore (simplebot_navigation/move_base) decides, this node converts messages,
owns the ROS interfaces of docs/design.md §7, and runs the control cycle on a timer of the node's clock.
"""

from __future__ import annotations

import math
import sys
import time

from actionlib_msgs.msg import GoalID, GoalStatus as ActionlibStatus
from geometry_msgs.msg import PoseStamped, Twist
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.task import Future

from move_base_msgs.action import MoveBase
from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.cycle_stats import ControlLoopStats
from simplebot_navigation.move_base.events import MoveBaseEvents
from simplebot_navigation.move_base.plugins import GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS, plugin_namespace
from simplebot_navigation.move_base.recovery import PoseTrail
from simplebot_navigation.move_base.state_machine import MoveBaseCore
from simplebot_navigation.parameters import fields_of
from simplebot_navigation.ros.conversions import pose_to_xyyaw, xyyaw_to_pose
from simplebot_navigation.ros.costmap.costmap_ros import Costmap2DROS
from simplebot_navigation.ros.move_base.move_base_goal import MoveBaseGoal
from simplebot_navigation.ros.poses import in_frame, validate_pose
from simplebot_navigation.ros.move_base.move_base_parameters import MoveBaseLiveParameters, declare_behavior_server
from simplebot_navigation.ros.move_base.move_base_recoveries import MoveBaseRecoveryContext
from simplebot_navigation.ros.move_base.move_base_services import serve_move_base_services
from simplebot_navigation.ros.move_base.move_base_stats import OUTCOMES, MoveBaseReports
from simplebot_navigation.ros.move_base.move_base_supervision import MoveBaseSupervisor
from simplebot_navigation.ros.move_base.nav2_front_door import Nav2FrontDoor
from simplebot_navigation.ros.move_base.external_obstacles import ExternalObstacles
from simplebot_navigation.ros.move_base.obstacle_feed import tf_obstacle_feed
from simplebot_navigation.ros.move_base.obstacle_tracking import ObstacleTracking
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.publishers import create_publisher, drop_event_handlers_of_best_effort_subscriptions
from simplebot_navigation.ros.qos import SERVICE_QOS
from simplebot_navigation.ros.tf import Buffer, TransformListener
from simplebot_navigation.ros.node_main import run_node

# The watchdog, status and diagnostics share one steady-clock timer (one executor wake-up where three
# timers would each wake it): the watchdog every tick, status every STATUS_TICKS, diagnostics every 10.
HOUSEKEEPING_PERIOD_S = 0.1
STATUS_TICKS = 2
DIAGNOSTICS_TICKS = 10
MISSED_RATE_WARNING_PERIOD_S = 5.0


class MoveBaseNode(Node):
    def __init__(self, **kwargs):
        started = time.perf_counter()
        kwargs.setdefault("automatically_declare_parameters_from_overrides", True)
        super().__init__("move_base", **kwargs)
        self.cfg = MoveBaseConfig.from_params(given_parameter_tree(self))
        for warning in self.cfg.warnings:
            self.get_logger().warn(warning)
        self._declare_own_defaults()
        self.behavior_server = declare_behavior_server(self)
        self.tf = Buffer(node=self)
        self.tf_listener = TransformListener(self.tf, self)
        # One obstacle feed for both costmaps and the local planner: the tracker, fed the local costmap's scans,
        # and other nodes' obstacles on the local planner's obstacles topic (docs/reference.md §6.3).
        self.obstacle_tracking = ObstacleTracking(self, self.tf)
        self.obstacle_feed = tf_obstacle_feed(self, self.tf, (self.obstacle_tracking,))
        self.global_costmap = Costmap2DROS(self, "global_costmap", self.tf, obstacle_feed=self.obstacle_feed)
        self.local_costmap = Costmap2DROS(self, "local_costmap", self.tf, obstacle_feed=self.obstacle_feed,
                                          scan_observer=self.obstacle_tracking.on_scan)
        self.external_obstacles = ExternalObstacles(
            self, f"~/{plugin_namespace(self.cfg.base_local_planner)}/obstacles", self.local_costmap.global_frame,
            self.tf, self.obstacle_tracking.params.external_timeout)
        self.obstacle_feed.add(self.external_obstacles)
        self.planner = GLOBAL_PLANNERS.spec(self.cfg.base_global_planner).load()(
            self, self.cfg.base_global_planner, self.global_costmap)
        self.controller = LOCAL_PLANNERS.spec(self.cfg.base_local_planner).load()(
            self, self.cfg.base_local_planner, self.local_costmap, self.tf, self.cfg.controller_frequency,
            self.global_costmap.global_frame, self.obstacle_feed)
        self.trail = PoseTrail()
        self.core = MoveBaseCore(self.cfg, self._build_recoveries(), self._plan_to, self.controller,
                                 self.planner.blocked_poses, self.trail)

        self.cmd_vel_pub = create_publisher(self, Twist, "cmd_vel", 1)
        self.current_goal_pub = create_publisher(self, PoseStamped, "~/current_goal", 1)
        group = ReentrantCallbackGroup()
        self.action_server = ActionServer(self, MoveBase, "move_base", execute_callback=self._execute,
                                          goal_callback=lambda _req: GoalResponse.ACCEPT,
                                          cancel_callback=lambda _handle: CancelResponse.ACCEPT,
                                          callback_group=group, goal_service_qos_profile=SERVICE_QOS,
                                          result_service_qos_profile=SERVICE_QOS,
                                          cancel_service_qos_profile=SERVICE_QOS)
        self.create_subscription(PoseStamped, "move_base_simple/goal", self._on_simple_goal, 1)
        self.create_subscription(GoalID, "~/cancel", self._on_cancel, 1)
        serve_move_base_services(self)

        self.goal: MoveBaseGoal | None = None
        self.finished: list[MoveBaseGoal] = []
        self.period = 1.0 / self.cfg.controller_frequency
        self.cycle_stats = ControlLoopStats(self.period)
        self._last_missed_warning = -math.inf
        self._control_timer = self.create_timer(self.period, self._control_cycle)
        self.supervisor = MoveBaseSupervisor(self)
        self.reports = MoveBaseReports(self)
        # On the steady clock: the watchdog, status and diagnostics must keep going when /clock stops.
        self._housekeeping_ticks = 0
        self.create_timer(HOUSEKEEPING_PERIOD_S, self._housekeeping, clock=Clock(clock_type=ClockType.STEADY_TIME))
        drop_event_handlers_of_best_effort_subscriptions(self)
        self.live_parameters = MoveBaseLiveParameters(self)
        self.nav2 = Nav2FrontDoor(self)
        self.get_logger().info(f"move_base ready: {self.cfg.base_global_planner} + {self.cfg.base_local_planner}, "
                               f"controller {self.cfg.controller_frequency:g} Hz, "
                               f"{len(self.core.recoveries)} recovery behaviours "
                               f"(start-up {time.perf_counter() - started:.1f} s)")

    # -- public state for tests and the scenario runner ---------------------------------------------
    @property
    def state(self) -> str:
        return self.core.state.value

    @property
    def events(self) -> MoveBaseEvents:
        """Counters and recent history of goals, plans, recoveries and outcomes."""
        return self.core.events

    @property
    def replans(self) -> int:
        return self.core.events.replans

    @property
    def recoveries(self) -> int:
        return sum(self.core.events.recoveries.values())

    # -- set-up ---------------------------------------------------------------------------------
    def _declare_own_defaults(self) -> None:
        own = {k: v for k, v in vars(self.cfg).items() if k not in ("warnings", "recovery_behaviors")}
        declare_defaults(self, own, specs=fields_of(MoveBaseConfig))

    def _build_recoveries(self) -> list:
        """One instance per behaviour name (a name listed twice runs the same instance twice), its parameters
        declared as it runs with them (as ROS 1's move_base sets reset_distance)."""
        tree = given_parameter_tree(self)
        behaviors, instances = [], {}
        self.recovery_instances = instances
        context = self.recovery_context = MoveBaseRecoveryContext(self, self.trail)
        for entry in self.cfg.recovery_behaviors:
            name = entry["name"]
            if name not in instances:
                params = tree.get(name) if isinstance(tree.get(name), dict) else {}
                instances[name] = RECOVERY_BEHAVIORS.spec(entry["type"]).load()(context, name, params)
                declare_defaults(self, instances[name].parameters(), prefix=name)
                for warning in instances[name].warnings:
                    self.get_logger().warn(warning)
            behaviors.append(instances[name])
        return behaviors

    # -- planning ---------------------------------------------------------------------------------
    def _robot_pose_global(self):
        return self.global_costmap.get_robot_pose()

    def _plan_to(self, goal_xyyaw):
        start = self._robot_pose_global()
        if start is None:
            self.get_logger().warn(f"cannot plan: no robot pose in {self.global_costmap.global_frame}: "
                                   f"{self.global_costmap.last_pose_error}", throttle_duration_sec=2.0)
            return f"no robot pose in {self.global_costmap.global_frame}"
        result = self.planner.make_plan(start[:3], goal_xyyaw)
        return result.poses if result.ok else result.message

    # -- goals --------------------------------------------------------------------------------------
    def _on_simple_goal(self, msg: PoseStamped) -> None:
        self._accept_goal(MoveBaseGoal(msg))

    async def _execute(self, handle):
        goal = MoveBaseGoal(handle.request.target_pose, handle,
                            feedback=lambda pose: handle.publish_feedback(self._move_base_feedback(pose)))
        goal.done = Future()
        self._accept_goal(goal)
        status = await goal.done
        if status == ActionlibStatus.SUCCEEDED:
            handle.succeed()
        elif status == ActionlibStatus.PREEMPTED and handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        return MoveBase.Result()

    def _move_base_feedback(self, pose) -> MoveBase.Feedback:
        feedback = MoveBase.Feedback()
        feedback.base_position.header.frame_id = self.global_costmap.global_frame
        feedback.base_position.header.stamp = pose.stamp.to_msg()
        feedback.base_position.pose = xyyaw_to_pose(*pose[:3])
        return feedback

    def take_over(self, goal: MoveBaseGoal) -> None:
        """``goal`` becomes the active one: the one before it, from whichever interface, is preempted."""
        if self.goal is not None:
            self._finish(self.goal, ActionlibStatus.PREEMPTED, "preempted by a new goal")
        goal.status = ActionlibStatus.ACTIVE
        self.goal = goal
        self.core.events.goal(self.now_s(), goal.id)
        self.supervisor.goal_accepted()

    def _accept_goal(self, goal: MoveBaseGoal) -> None:
        self.take_over(goal)
        reason, cause = validate_pose(goal.pose), "invalid_goal"
        target = None
        if reason is None:
            target, reason, cause = self.goal_in_global_frame(goal.pose)
        if reason is not None:
            self.get_logger().error(f"Aborting on goal because it was sent with an invalid goal: {reason}")
            self.end_goal(goal, ActionlibStatus.ABORTED, reason, cause)
            return
        self.current_goal_pub.publish(target)
        xyyaw = pose_to_xyyaw(target.pose)
        self.get_logger().info(f"new goal ({xyyaw[0]:.2f}, {xyyaw[1]:.2f}, yaw {xyyaw[2]:.2f}) "
                               f"in {target.header.frame_id}")
        self.publish_zero()
        self.core.set_goal(xyyaw, self.now_s())

    def goal_in_global_frame(self, pose: PoseStamped, role: str = "goal"):
        """(the pose in the global frame, None, "") or (None, why not, the cause for Nav2's error code)."""
        frame = self.global_costmap.global_frame
        target, reason = in_frame(pose, frame, self.tf, role)
        if target is None:
            return None, reason, "transform"
        x, y = target.pose.position.x, target.pose.position.y
        master = self.global_costmap.costmap
        if master.world_to_map(x, y) is None:
            x1, y1 = master.origin_x + master.size_x * master.resolution, \
                master.origin_y + master.size_y * master.resolution
            return None, (f"{role} ({x:.6g}, {y:.6g}) is outside the global costmap "
                          f"[{master.origin_x:.2f}, {x1:.2f}] x [{master.origin_y:.2f}, {y1:.2f}] in {frame}"), \
                "goal_outside_map"
        return target, None, ""

    def start_behavior(self, goal: MoveBaseGoal) -> None:
        """A Nav2 behaviour (goal.behavior) becomes the active goal, from the robot's pose now."""
        self.take_over(goal)
        self.core.reset()
        self.publish_zero()
        pose = self._robot_pose_global()
        if pose is None:
            self.end_goal(goal, ActionlibStatus.ABORTED, f"no robot pose in {self.global_costmap.global_frame}: "
                                                         f"{self.global_costmap.last_pose_error}", "TF_ERROR")
            return
        goal.behavior.start(self.now_s(), pose[:3])

    def _on_cancel(self, msg: GoalID) -> None:
        if self.goal is not None and (not msg.id or msg.id == self.goal.id):
            self.get_logger().info("goal canceled")
            self.end_goal(self.goal, ActionlibStatus.PREEMPTED, "canceled")

    def end_goal(self, goal: MoveBaseGoal, status: int, text: str, cause: str = "") -> None:
        """End a goal from outside the state machine (cancel, preemption, an error): stop the robot, drop the
        goal from the state machine, and report the end."""
        self.core.reset()
        self.publish_zero()
        self._finish(goal, status, text, cause)

    def _finish(self, goal: MoveBaseGoal, status: int, text: str, cause: str = "") -> None:
        goal.status, goal.text, goal.cause = status, text, cause
        goal.finished_wall = time.monotonic()
        self.core.events.outcome(self.now_s(), OUTCOMES.get(status, f"status {status}"), text)
        if goal is self.goal:
            self.goal = None
        self.finished.append(goal)
        if goal.done is not None and not goal.done.done():
            goal.done.set_result(status)
        self.reports.publish_status()

    # -- the control cycle --------------------------------------------------------------------------
    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds / 1e9

    def _housekeeping(self) -> None:
        self._housekeeping_ticks += 1
        self.cycle_stats.account(self.now_s())
        self.supervisor.check_watchdog()
        if self._housekeeping_ticks % STATUS_TICKS == 0:
            self.reports.publish_status()
        if self._housekeeping_ticks % DIAGNOSTICS_TICKS == 0:
            self.reports.publish_diagnostics()

    def _control_cycle(self) -> None:
        self.cycle_stats.ran(self.now_s())
        self.supervisor.loop_ran()
        self.live_parameters.apply_pending()
        goal = self.goal
        if goal is None:
            return
        if goal.handle is not None and goal.handle.is_cancel_requested:
            self.end_goal(goal, ActionlibStatus.PREEMPTED, "canceled")
            return
        started = time.perf_counter()
        pose = self._robot_pose_global()
        if pose is None:
            self.publish_zero()
            self.get_logger().warn(f"waiting for the robot pose: {self.global_costmap.last_pose_error}",
                                   throttle_duration_sec=5.0)
            self.supervisor.wait_for_data(f"no robot pose: {self.global_costmap.last_pose_error}")
            return
        if goal.behavior is not None:
            self._behavior_cycle(goal, pose)
            return
        if goal.advance is not None:
            target = goal.advance(pose)
            if target is not None:
                self.core.set_goal(target, self.now_s())
        if goal.feedback is not None:
            goal.feedback(pose)
        stale = self.local_costmap.stale_sources()
        if stale:
            self.supervisor.wait_for_data(f"sensor data out of date: {', '.join(f'local_costmap/{s}' for s in stale)}")
            if self.goal is None:
                return
        else:
            self.supervisor.data_ok()
        try:
            out = self.core.cycle(self.now_s(), pose[:3], self.local_costmap.is_current(),
                                  ", ".join(f"local_costmap/{s}" for s in stale))
        except Exception as exc:  # noqa: BLE001 - a bug in a planner must stop the robot, not the node
            self.supervisor.abort_on_internal_error(goal, exc)
            return
        if out.cmd is not None:
            self._publish_cmd(*out.cmd)
        if out.event:
            self.get_logger().info(out.event)
        if out.outcome == "succeeded":
            self.get_logger().info("Goal reached")
            self._finish(goal, ActionlibStatus.SUCCEEDED, out.message)
        elif out.outcome == "aborted":
            self.get_logger().error(out.message)
            self._finish(goal, ActionlibStatus.ABORTED, out.message, out.cause)
        elif out.message:
            self.get_logger().warn(out.message, throttle_duration_sec=2.0)
        elapsed = time.perf_counter() - started
        if self.cycle_stats.add(elapsed) and time.monotonic() - self._last_missed_warning >= MISSED_RATE_WARNING_PERIOD_S:
            self._last_missed_warning = time.monotonic()
            self.get_logger().warn(f"Control loop missed its desired rate of {self.cfg.controller_frequency:.4f}Hz"
                                   f"... the loop actually took {elapsed:.4f} seconds")

    def _behavior_cycle(self, goal: MoveBaseGoal, pose) -> None:
        """One step of a Nav2 behaviour (Spin, BackUp, ...): it drives while the local costmap is current."""
        stale = self.local_costmap.stale_sources()
        if stale:
            self.publish_zero()
            self.supervisor.wait_for_data(f"sensor data out of date: {', '.join(f'local_costmap/{s}' for s in stale)}")
            return
        self.supervisor.data_ok()
        step = goal.behavior.tick(self.now_s(), pose[:3])
        self._publish_cmd(*step.cmd)
        if goal.feedback is not None:
            goal.feedback(pose)
        if step.outcome == "":
            self.get_logger().info(step.message)
            self._finish(goal, ActionlibStatus.SUCCEEDED, step.message)
        elif step.outcome is not None:
            self.get_logger().error(step.message)
            self._finish(goal, ActionlibStatus.ABORTED, step.message, step.outcome)

    def destroy_node(self) -> None:
        self.supervisor.stop()
        super().destroy_node()

    def set_controller_frequency(self, hz: float) -> None:
        """The control timer, its statistics and the local planner follow the new rate from now on."""
        self.period = 1.0 / hz
        self._control_timer.timer_period_ns = round(self.period * 1e9)
        self._control_timer.reset()          # the next cycle one new period from now
        self.cycle_stats.set_period(self.period)
        self.controller.set_controller_frequency(hz)

    def _publish_cmd(self, v: float, omega: float) -> None:
        twist = Twist()
        twist.linear.x, twist.angular.z = float(v), float(omega)
        self.cmd_vel_pub.publish(twist)

    def publish_zero(self) -> None:
        self._publish_cmd(0.0, 0.0)


def main(args=None) -> int:
    return run_node("move_base", MoveBaseNode, args)

if __name__ == "__main__":
    sys.exit(main())
