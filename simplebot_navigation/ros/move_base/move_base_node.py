"""The move_base node: costmaps, planner and controller plugins, the state machine, and its interfaces.

A thin shell: MoveBaseCore (simplebot_navigation/move_base) decides, this node converts messages,
owns the ROS interfaces of docs/design.md §7, and runs the control cycle on a timer of the node's clock.
"""

from __future__ import annotations

import math
import sys
import time

from actionlib_msgs.msg import GoalID, GoalStatus as ActionlibStatus, GoalStatusArray
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.srv import GetPlan
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_srvs.srv import Empty

from move_base_msgs.action import MoveBase
from simplebot_navigation.move_base.behaviors import BehaviorServerParams
from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.cycle_stats import ControlLoopStats
from simplebot_navigation.move_base.events import MoveBaseEvents
from simplebot_navigation.move_base.parameter_tree import BEHAVIOR_SERVER, crowd_planner
from simplebot_navigation.move_base.planner_switch import LocalPlannerSwitch, feed_near
from simplebot_navigation.move_base.plugins import GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS, plugin_namespace
from simplebot_navigation.move_base.recovery import PoseTrail
from simplebot_navigation.move_base.state_machine import MoveBaseCore
from simplebot_navigation.parameters import fields_of
from simplebot_navigation.ros.costmap.costmap_ros import Costmap2DROS
from simplebot_navigation.ros.costmap.costmap_services import CostmapServices
from simplebot_navigation.ros.lifecycle_state import serve_lifecycle_state
from simplebot_navigation.ros.move_base.cycle_poses import CyclePoses
from simplebot_navigation.ros.move_base.goal_arbiter import GoalArbiter
from simplebot_navigation.ros.move_base.move_base_front_door import MoveBaseFrontDoor
from simplebot_navigation.ros.move_base.move_base_goal import GoalCheck, MoveBaseGoal
from simplebot_navigation.ros.move_base.move_base_parameters import MoveBaseLiveParameters
from simplebot_navigation.ros.move_base.move_base_recoveries import MoveBaseRecoveryContext
from simplebot_navigation.ros.move_base.move_base_services import MoveBaseServices
from simplebot_navigation.ros.move_base.move_base_stats import MoveBaseReports
from simplebot_navigation.ros.move_base.move_base_supervision import MoveBaseSupervisor
from simplebot_navigation.ros.move_base.nav2_front_door import Nav2FrontDoor
from simplebot_navigation.ros.move_base.external_obstacles import ExternalObstacles
from simplebot_navigation.ros.move_base.obstacle_feed import tf_obstacle_feed
from simplebot_navigation.ros.move_base.obstacle_tracking import ObstacleTracking
from simplebot_navigation.ros.params import (declare_defaults, describe_declared, given_parameter_tree,
                                             refuse_unknown_parameters)
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
    """Assembled in the order of what each part needs: parameters; TF; the obstacle feed; the costmaps; the
    plugins; the cycle's poses, the recoveries, the state machine and the goal arbiter; then the front doors, the
    loops (supervisor, reports) and live parameters, each given only parts built before it."""

    def __init__(self, **kwargs):
        started = time.perf_counter()
        kwargs.setdefault("automatically_declare_parameters_from_overrides", True)
        super().__init__("move_base", **kwargs)
        log = self.get_logger()
        self.cfg = MoveBaseConfig.from_params(given_parameter_tree(self))
        for warning in self.cfg.warnings:
            log.warn(warning)
        self._declare_own_defaults()
        self.behavior_server = self._declare_behavior_server()
        self.tf = Buffer(node=self)
        self.tf_listener = TransformListener(self.tf, self)
        # One obstacle feed for both costmaps and the local planner: the tracker, fed the local costmap's scans,
        # and other nodes' obstacles on the local planner's obstacles topic (docs/reference.md §6.3).
        self.obstacle_tracking = ObstacleTracking(self, self.tf)
        self.obstacle_feed = tf_obstacle_feed(self, self.tf, (self.obstacle_tracking,))
        self.global_costmap = Costmap2DROS(self, "global_costmap", self.tf, obstacle_feed=self.obstacle_feed)
        self.local_costmap = Costmap2DROS(self, "local_costmap", self.tf, obstacle_feed=self.obstacle_feed,
                                          scan_observer=self.obstacle_tracking.on_scan)
        self.obstacle_tracking.robot_frame = self.local_costmap.robot_base_frame
        self.external_obstacles = ExternalObstacles(
            self, f"~/{plugin_namespace(self.cfg.base_local_planner)}/obstacles", self.local_costmap.global_frame,
            self.tf, self.obstacle_tracking.params.external_timeout)
        self.obstacle_feed.add(self.external_obstacles)
        self.planner = GLOBAL_PLANNERS.spec(self.cfg.base_global_planner).load()(
            self, self.cfg.base_global_planner, self.global_costmap)
        self.controller, self.crowd_controller = (None if plugin_type is None else LOCAL_PLANNERS.spec(
            plugin_type).load()(self, plugin_type, self.local_costmap, self.tf, self.cfg.controller_frequency,
                                self.global_costmap.global_frame, self.obstacle_feed)
            for plugin_type in (self.cfg.base_local_planner, crowd_planner(self.cfg)))
        # who drives when: the base planner, or the crowd planner while moving obstacles are near
        near = feed_near(self.obstacle_feed, self.local_costmap.global_frame, lambda: self.local_costmap.footprint,
                         self.cfg, self.now_s)
        self.local_planners = LocalPlannerSwitch(self.controller, self.crowd_controller, near, self.cfg, self.now_s,
                                                 self._handed_over,
                                                 (self.cfg.base_local_planner, self.cfg.crowd_local_planner))

        # The robot's pose, read once per control cycle, for everything that cycle runs.
        self.poses = CyclePoses(self.global_costmap, self.local_costmap)
        self.trail = PoseTrail()
        self.recovery_context = MoveBaseRecoveryContext(self.poses, self.trail, given_parameter_tree(self),
                                                        self.cfg.conservative_reset_dist)
        self.recovery_instances: dict = {}
        self.core = MoveBaseCore(self.cfg, self._build_recoveries(), self._plan, self.local_planners,
                                 self.planner.blocked_poses, self.trail)
        self.cmd_vel_pub = create_publisher(self, Twist, "cmd_vel", 1)
        current_goal_pub = create_publisher(self, PoseStamped, "~/current_goal", 1)
        self.arbiter = GoalArbiter(self.core, self.publish_zero, self.now_s, log, current_goal_pub.publish)
        self.check_goal = GoalCheck(self.global_costmap)
        self.period = 1.0 / self.cfg.controller_frequency
        self._serve_front_doors(log)
        self._start_loops(log)
        self._take_live_parameters(log)
        crowd = f" (among moving obstacles {self.cfg.crowd_local_planner})" if self.crowd_controller else ""
        log.info(f"move_base ready: {self.cfg.base_global_planner} + {self.cfg.base_local_planner}{crowd}, "
                 f"controller {self.cfg.controller_frequency:g} Hz, {len(self.core.recoveries)} recovery behaviours "
                 f"(start-up {time.perf_counter() - started:.1f} s)")

    def _serve_front_doors(self, log) -> None:
        """Every interface that asks for a goal, a plan or a cleared costmap: each checks a request once and hands
        a goal to the arbiter."""
        self.nav2 = Nav2FrontDoor(self.arbiter, self.check_goal, self.core, self.planner, self.cfg.base_global_planner,
                                  self.global_costmap, self.get_clock(), log, self.recovery_context.footprint_clear,
                                  lambda: self.period, lambda: self.behavior_server)
        own = MoveBaseFrontDoor(self.arbiter, self.check_goal)
        self.action_servers = serve_actions(self, ((MoveBase, "move_base", own.execute),) + self.nav2.actions)
        self.create_subscription(PoseStamped, "move_base_simple/goal", own.on_simple_goal, 1)
        self.create_subscription(GoalID, "~/cancel", lambda msg: self.arbiter.cancel(msg.id), 1)
        services = MoveBaseServices(self.arbiter, self.planner, self.global_costmap, self.local_costmap,
                                    self.get_clock(), log)
        self.create_service(GetPlan, "~/make_plan", services.make_plan, qos_profile=SERVICE_QOS)
        self.create_service(Empty, "~/clear_costmaps", services.clear_costmaps, qos_profile=SERVICE_QOS)
        self.costmap_services = [CostmapServices(self, costmap, costmap.name)
                                 for costmap in (self.global_costmap, self.local_costmap)]
        serve_lifecycle_state(self, "bt_navigator",
                              lambda: self.global_costmap.initialized and self.local_costmap.initialized)

    def _start_loops(self, log) -> None:
        """The control cycle on node time; the watchdog, status and diagnostics on the steady clock, so they keep
        going when /clock stops."""
        self.cycle_stats = ControlLoopStats(self.period)
        self._last_missed_warning = -math.inf
        self._control_timer = self.create_timer(self.period, self._control_cycle)
        self.supervisor = MoveBaseSupervisor(self.get_clock(), log, self.cfg, self.arbiter, self._forget_history)
        self.reports = MoveBaseReports(create_publisher(self, GoalStatusArray, "~/status", 1),
                                       create_publisher(self, DiagnosticArray, "/diagnostics", 10),
                                       self.get_clock(), self.get_name(), self.arbiter, self.cycle_stats,
                                       self.core.events, self.cfg)
        self._housekeeping_ticks = 0
        self.create_timer(HOUSEKEEPING_PERIOD_S, self._housekeeping, clock=Clock(clock_type=ClockType.STEADY_TIME))
        drop_event_handlers_of_best_effort_subscriptions(self)

    def _take_live_parameters(self, log) -> None:
        """Last: every part has declared its parameters."""
        self.live_parameters = MoveBaseLiveParameters(
            given_parameter_tree(self), log, cfg=self.cfg, global_costmap=self.global_costmap,
            local_costmap=self.local_costmap, planner=self.planner, controller=self.local_planners,
            recoveries=self.recovery_instances, tracking=self.obstacle_tracking, external=self.external_obstacles,
            set_controller_frequency=self.set_controller_frequency, set_behavior_server=self._set_behavior_server)
        describe_declared(self, self.live_parameters.table)
        refuse_unknown_parameters(self)
        self.add_pre_set_parameters_callback(self.live_parameters.normalize)
        self.add_on_set_parameters_callback(self.live_parameters.check)
        self.add_post_set_parameters_callback(self.live_parameters.stored)

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

    @property
    def goal(self):
        """The active MoveBaseGoal, or None (the arbiter's)."""
        return self.arbiter.active

    # -- set-up ---------------------------------------------------------------------------------
    def _declare_own_defaults(self) -> None:
        own = {k: v for k, v in vars(self.cfg).items() if k not in ("warnings", "recovery_behaviors")}
        declare_defaults(self, own, specs=fields_of(MoveBaseConfig))

    def _declare_behavior_server(self) -> BehaviorServerParams:
        """The limits of Nav2's behaviours (``behavior_server.*``) the node starts with, declared as they are used."""
        params = BehaviorServerParams.from_params(given_parameter_tree(self, BEHAVIOR_SERVER),
                                                  f"move_base/{BEHAVIOR_SERVER}")
        for warning in params.warnings:
            self.get_logger().warn(warning)
        specs = fields_of(BehaviorServerParams)
        declare_defaults(self, {name: getattr(params, name) for name in specs}, prefix=BEHAVIOR_SERVER, specs=specs)
        return params

    def _set_behavior_server(self, params: BehaviorServerParams) -> None:
        """New limits for Nav2's behaviours requested from now on (a running one keeps its own)."""
        self.behavior_server = params

    def _build_recoveries(self) -> list:
        """One instance per behaviour name (a name listed twice runs the same instance twice), its parameters
        declared as it runs with them (as ROS 1's move_base sets reset_distance)."""
        tree = given_parameter_tree(self)
        behaviors, instances = [], self.recovery_instances
        for entry in self.cfg.recovery_behaviors:
            name = entry["name"]
            if name not in instances:
                params = tree.get(name) if isinstance(tree.get(name), dict) else {}
                instances[name] = RECOVERY_BEHAVIORS.spec(entry["type"]).load()(self.recovery_context, name, params)
                declare_defaults(self, instances[name].parameters(), prefix=name)
                for warning in instances[name].warnings:
                    self.get_logger().warn(warning)
            behaviors.append(instances[name])
        return behaviors

    def _forget_history(self) -> None:
        """Time jumped back: what the costmaps, the tracker and the controller kept belongs to another timeline."""
        for costmap in (self.global_costmap, self.local_costmap):
            costmap.forget_history()
        self.obstacle_tracking.reset()
        self.local_planners.reset()

    def _handed_over(self, planner: str, why: str) -> None:
        self.get_logger().info(f"local planner: {planner} drives ({why})")
        self.core.events.handover(self.now_s(), planner, why)

    # -- planning ---------------------------------------------------------------------------------
    def _plan(self, start, goal_xyyaw):
        """The state machine's planner: from this cycle's robot pose (``start``) to the goal."""
        result = self.planner.make_plan(start, goal_xyyaw)
        return result.poses if result.ok else result.message

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
        goal = self.arbiter.active
        if goal is None:
            return
        if goal.handle is not None and goal.handle.is_cancel_requested:
            self.arbiter.finish(goal, ActionlibStatus.PREEMPTED, "canceled")
            return
        started = time.perf_counter()
        pose = self.poses.read()
        if goal.behavior is not None and not goal.behavior_started:
            if not self._start_behavior(goal, pose):
                return
        if pose is None:
            self.publish_zero()
            self.get_logger().warn(f"waiting for the robot pose: {self.global_costmap.last_pose_error}",
                                   throttle_duration_sec=5.0)
            self.supervisor.wait_for_data(f"no robot pose: {self.global_costmap.last_pose_error}")
            return
        if goal.behavior is not None:
            self._behavior_cycle(goal, pose)
            return
        self.local_planners.begin_cycle(self.poses.in_local)
        if goal.advance is not None:
            target = goal.advance(pose)
            if target is not None:
                self.core.set_goal(target, self.now_s())
        if goal.feedback is not None:
            goal.feedback(pose)
        stale = self.local_costmap.stale_sources()
        if stale:
            self.supervisor.wait_for_data(f"sensor data out of date: {', '.join(f'local_costmap/{s}' for s in stale)}")
            if self.arbiter.active is None:
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
            self.arbiter.finish(goal, ActionlibStatus.SUCCEEDED, out.message)
        elif out.outcome == "aborted":
            self.get_logger().error(out.message)
            self.arbiter.finish(goal, ActionlibStatus.ABORTED, out.message, out.cause)
        elif out.message:
            self.get_logger().warn(out.message, throttle_duration_sec=2.0)
        elapsed = time.perf_counter() - started
        if self.cycle_stats.add(elapsed) and time.monotonic() - self._last_missed_warning >= MISSED_RATE_WARNING_PERIOD_S:
            self._last_missed_warning = time.monotonic()
            self.get_logger().warn(f"Control loop missed its desired rate of {self.cfg.controller_frequency:.4f}Hz"
                                   f"... the loop actually took {elapsed:.4f} seconds")

    def _start_behavior(self, goal: MoveBaseGoal, pose) -> bool:
        """A Nav2 behaviour starts from the first pose its cycles read; without one it ends at once (TF_ERROR)."""
        if pose is None:
            self.arbiter.finish(goal, ActionlibStatus.ABORTED, f"no robot pose in {self.global_costmap.global_frame}: "
                                                               f"{self.global_costmap.last_pose_error}", "TF_ERROR")
            return False
        goal.behavior.start(self.now_s(), pose[:3])
        goal.behavior_started = True
        return True

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
            self.arbiter.finish(goal, ActionlibStatus.SUCCEEDED, step.message)
        elif step.outcome is not None:
            self.get_logger().error(step.message)
            self.arbiter.finish(goal, ActionlibStatus.ABORTED, step.message, step.outcome)

    def destroy_node(self) -> None:
        self.supervisor.stop()
        super().destroy_node()

    def set_controller_frequency(self, hz: float) -> None:
        """The control timer, its statistics and the local planner follow the new rate from now on."""
        self.period = 1.0 / hz
        self._control_timer.timer_period_ns = round(self.period * 1e9)
        self._control_timer.reset()          # the next cycle one new period from now
        self.cycle_stats.set_period(self.period)
        self.local_planners.set_controller_frequency(hz)

    def _publish_cmd(self, v: float, omega: float) -> None:
        twist = Twist()
        twist.linear.x, twist.angular.z = float(v), float(omega)
        self.cmd_vel_pub.publish(twist)

    def publish_zero(self) -> None:
        self._publish_cmd(0.0, 0.0)


#: seconds a finished goal's result stays available to clients (rclpy's default is 900 s). In lockstep runs that
#: sent goals for longer than 900 s of sim time, rcl's result-expiry timer kept firing at one frozen instant (945
#: and 948 s in two exploration runs; the simulator's clock waits for idle nodes, so it never moved again). A day
#: keeps the results of every goal of a day's run (a few kilobytes each) and stays clear of that
RESULT_TIMEOUT_S = 86400.0


def serve_actions(node: Node, actions) -> list[ActionServer]:
    """An action server per (action type, name, execute callback), every goal accepted (the arbiter preempts)."""
    group = ReentrantCallbackGroup()
    return [ActionServer(node, action, name, execute_callback=execute, callback_group=group,
                         result_timeout=RESULT_TIMEOUT_S,
                         goal_callback=lambda _request: GoalResponse.ACCEPT,
                         cancel_callback=lambda _handle: CancelResponse.ACCEPT, goal_service_qos_profile=SERVICE_QOS,
                         result_service_qos_profile=SERVICE_QOS, cancel_service_qos_profile=SERVICE_QOS)
            for action, name, execute in actions]


def main(args=None) -> int:
    return run_node("move_base", MoveBaseNode, args)

if __name__ == "__main__":
    sys.exit(main())
