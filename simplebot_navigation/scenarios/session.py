"""The simulator and move_base of the navigation launch file, with a goal client, in two ways.

NavigationSession builds the nodes in this process from ``load_launch('navigation', ...)``, with
the same parameter files and ``--ros-args`` as ``python -m simplebot_navigation.launch navigation
--single-process``; only the simulator's seed and lidar noise are added. With ``rtf == 0`` a
LockstepDriver steps them (same seed, same run); with ``rtf > 0`` the simulator runs against the
wall clock and one executor spins everything, so a machine too slow for that factor shows it.
ProcessSession (process_session.py) runs the launcher itself, each node in its own process, at ``rtf > 0``.
"""

from __future__ import annotations

import abc
import dataclasses
import importlib
import math
import tempfile
import time
import uuid
from dataclasses import dataclass
from typing import Callable

import rclpy
from action_msgs.msg import GoalStatus
from actionlib_msgs.msg import GoalStatusArray
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from move_base_msgs.action import MoveBase
from simplebot_description import RobotDescription, robot_description
from simplebot_navigation.geometry import pose_in_frame
from simplebot_navigation.launch.loader import load_launch
from simplebot_navigation.launch.nodes import resolve_executable
from simplebot_navigation.launch.overrides import apply_set, speed_assignments
from simplebot_navigation.launch.runner import ros_args, write_params_file
from simplebot_navigation.move_base.cycle_stats import CycleSnapshot
from simplebot_navigation.move_base.events import MoveBaseStats
from simplebot_navigation.move_base.plugins import plugin_namespace
from simplebot_navigation.ros.conversions import quaternion_msg, yaw_of
from simplebot_navigation.ros.qos import LATCHED, SERVICE_QOS
from simplebot_navigation.ros.simulator.lockstep import LockstepDriver
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from simplebot_navigation.scenarios.launch_args import launch_args
from simplebot_navigation.scenarios.true_obstacles import use_true_obstacles
from simplebot_navigation.sim.world import Pose2D, World
from simplebot_navigation.sim.world_loader import load_world

WARM_UP_S = 2.0
STATUS_NAMES = {GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED", GoalStatus.STATUS_ABORTED: "ABORTED",
                GoalStatus.STATUS_CANCELED: "CANCELED"}


@dataclass
class GoalRun:
    """One goal sent through the move_base action: its futures, then its outcome as they complete."""

    goal: Pose2D
    sent_at: float
    send_future: object
    result_future: object | None = None
    handle: object | None = None
    finished_at: float | None = None
    status: str | None = None       # SUCCEEDED, ABORTED, CANCELED, REJECTED
    reason: str = ""                # move_base's status text for the goal

    @property
    def done(self) -> bool:
        return self.status is not None


def goal_in_map(pose: Pose2D) -> MoveBase.Goal:
    """A MoveBase goal in the ``map`` frame: a world's, which every robot's odom hangs from, and a map's exported
    from it."""
    goal = MoveBase.Goal()
    goal.target_pose.header.frame_id = "map"
    goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = pose.x, pose.y
    goal.target_pose.pose.orientation = quaternion_msg(pose.yaw)
    return goal


class ScenarioClient(Node):
    """The user's side: goals through the action, ground truth, collisions and status from topics.

    Its names are relative: in ``namespace`` (robot1, say) it drives that robot of a multi-robot run.
    """

    def __init__(self, context, namespace: str = ""):
        super().__init__("scenario_runner", namespace=namespace, context=context,
                         parameter_overrides=[Parameter("use_sim_time", value=True)])
        self.frame_prefix = f"{namespace}/" if namespace else ""  # the robot's frames, as the simulator names them
        self.action = ActionClient(self, MoveBase, "move_base", goal_service_qos_profile=SERVICE_QOS,
                                   result_service_qos_profile=SERVICE_QOS,
                                   cancel_service_qos_profile=SERVICE_QOS)
        self.truth: list[tuple[float, float, float, float]] = []  # (t, x, y, yaw) in the world frame
        self.localized: list[tuple[float, float, float, float]] = []  # amcl's (t, x, y, yaw) in map, on a map
        self.collisions = 0              # the robot's own: it drove into something (simulator's count_moving)
        self.struck_standing = 0         # something ran into it while it stood (count_standing)
        self.status: GoalStatusArray | None = None
        #: goal id -> a GoalRun that ended before move_base's status told why (the result and the status topic
        #: are separate channels; between processes either may come first)
        self.awaiting_reason: dict[str, GoalRun] = {}
        self.create_subscription(Odometry, "simplebot/ground_truth", self._on_truth, 100)
        self.create_subscription(PoseWithCovarianceStamped, "amcl_pose", self._on_amcl_pose, 10)
        self.create_subscription(DiagnosticStatus, "simplebot/collisions", self._on_collisions, LATCHED)
        self.create_subscription(GoalStatusArray, "move_base/status", self._on_status, 10)

    def _on_truth(self, msg: Odometry) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        self.truth.append((stamp, p.x, p.y, yaw_of(q)))

    def _on_amcl_pose(self, msg: PoseWithCovarianceStamped) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        self.localized.append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, p.x, p.y, yaw_of(q)))

    def _on_collisions(self, msg: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        self.collisions, self.struck_standing = int(values["count_moving"]), int(values["count_standing"])

    def _on_status(self, msg: GoalStatusArray) -> None:
        self.status = msg
        for goal_id in [g for g in self.awaiting_reason if self.status_text(g)]:
            self.awaiting_reason.pop(goal_id).reason = self.status_text(goal_id)

    def record_commands(self) -> list[tuple[float, float, float]]:
        """From now on, (monotonic wall time, v, omega) of every cmd_vel the robot is sent: when it was told what,
        for tests and benches that check how fast the stack stops it."""
        commands: list[tuple[float, float, float]] = []
        self.create_subscription(Twist, "simplebot_controller/cmd_vel",
                                 lambda msg: commands.append((time.monotonic(), msg.linear.x, msg.angular.z)), 50)
        return commands

    def status_text(self, goal_id: str) -> str:
        """move_base's text for a goal in /move_base/status (why it aborted, say)."""
        if self.status is None:
            return ""
        return next((s.text for s in self.status.status_list if s.goal_id.id == goal_id), "")


@dataclass
class SessionStats:
    """What only an in-process move_base can give: its event counters and control cycle wall times."""

    navigation: MoveBaseStats
    cycles: CycleSnapshot


class _Session(abc.ABC):
    """What every way of running the stack shares: the client node, goals, the world frame, time loops."""

    world: World
    description: RobotDescription
    client: ScenarioClient
    context: rclpy.Context
    executor: SingleThreadedExecutor | None = None
    #: navigating on this map (a map YAML or a world's name); empty: in odom, the lab's way
    map_name: str = ""
    #: navigating on the map the slam node builds (in the world's frame, as a world's exported map is)
    slam: bool = False

    @property
    @abc.abstractmethod
    def time(self) -> float:
        """Simulated seconds."""

    @abc.abstractmethod
    def pose(self) -> Pose2D:
        """Ground-truth pose of the robot in the world frame."""

    @abc.abstractmethod
    def ready(self) -> bool:
        """move_base takes goals."""

    @abc.abstractmethod
    def close(self) -> None:
        """Stop every node and process of the session."""

    def stats(self) -> SessionStats | None:
        return None

    def run_until(self, sim_time_s: float | None = None, stop: Callable[[], bool] | None = None,
                  wall_timeout_s: float | None = None) -> bool:
        """Advance to sim_time_s or until stop(); True if stop() ended it. TimeoutError on the wall guard."""
        deadline = None if wall_timeout_s is None else time.monotonic() + wall_timeout_s
        while True:
            if stop is not None and stop():
                return True
            if sim_time_s is not None and self.time >= sim_time_s - 1e-6:
                return False
            if deadline is not None and time.monotonic() > deadline:
                raise TimeoutError(f"wall-clock guard of {wall_timeout_s:g} s expired at sim time {self.time:.2f} s")
            self.executor.spin_once(timeout_sec=0.005)

    def run_for(self, duration_s: float, stop: Callable[[], bool] | None = None,
                wall_timeout_s: float | None = None) -> bool:
        return self.run_until(self.time + duration_s, stop, wall_timeout_s)

    def spin_wall(self, seconds: float, stop: Callable[[], bool] = lambda: False) -> bool:
        """Spin for wall-clock seconds, or until stop(); for when simulated time may stop or jump back (a
        killed or restarted simulator). True if stop() ended it."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if stop():
                return True
            self.executor.spin_once(timeout_sec=0.02)
        return stop()

    def wait_ready(self, wall_timeout_s: float = 60.0) -> None:
        """Warm up: move_base ready for goals, and at least WARM_UP_S of sim time."""
        self.run_until(WARM_UP_S, wall_timeout_s=wall_timeout_s)
        if not self.run_until(None, self.ready, wall_timeout_s=wall_timeout_s):
            raise TimeoutError("move_base never became ready")

    @abc.abstractmethod
    def controller_param(self, name: str, default: float) -> float:
        """A parameter of the local planner (xy_goal_tolerance, max_vel_x...) as move_base runs it."""

    # -- goals ----------------------------------------------------------------------------------
    def to_odom(self, x: float, y: float, yaw: float) -> tuple[float, float, float]:
        """World pose -> the odom frame, which is the start pose (wheel odometry starts at zero)."""
        s = self.world.start
        return pose_in_frame((s.x, s.y, s.yaw), (x, y, yaw))

    def goal_message(self, goal: Pose2D) -> MoveBase.Goal:
        """A goal in odom, or on a map in ``map``: a map exported from the world has the world's coordinates."""
        on_map = bool(self.map_name) or self.slam
        x, y, yaw = (goal.x, goal.y, goal.yaw) if on_map else self.to_odom(goal.x, goal.y, goal.yaw)
        msg = MoveBase.Goal()
        pose: PoseStamped = msg.target_pose
        pose.header.frame_id = "map" if on_map else self.client.frame_prefix + "odom"
        pose.header.stamp = self.client.get_clock().now().to_msg()
        pose.pose.position.x, pose.pose.position.y = x, y
        pose.pose.orientation = quaternion_msg(yaw)
        return msg

    def send_goal(self, goal: Pose2D) -> GoalRun:
        """Send a goal (world frame) and return at once; the run fills in as time advances."""
        run = GoalRun(goal, self.time, self.client.action.send_goal_async(self.goal_message(goal)))
        run.send_future.add_done_callback(lambda future: self._on_goal_response(run, future))
        return run

    def _on_goal_response(self, run: GoalRun, future) -> None:
        run.handle = future.result()
        if not run.handle.accepted:
            self._finish(run, "REJECTED")
            return
        run.result_future = run.handle.get_result_async()
        run.result_future.add_done_callback(
            lambda result: self._finish(run, STATUS_NAMES.get(result.result().status,
                                                              f"status {result.result().status}")))

    def _finish(self, run: GoalRun, status: str) -> None:
        run.status = status
        run.finished_at = self.time
        goal_id = str(uuid.UUID(bytes=bytes(run.handle.goal_id.uuid)))
        run.reason = self.client.status_text(goal_id) if status != "SUCCEEDED" else ""
        if status != "SUCCEEDED" and not run.reason:
            self.client.awaiting_reason[goal_id] = run

    def cancel(self, run: GoalRun) -> None:
        if run.handle is not None and not run.done:
            run.handle.cancel_goal_async()

    def truth_since(self, t0: float, t1: float | None = None) -> list[tuple[float, float, float, float]]:
        return [s for s in self.client.truth if s[0] >= t0 - 1e-9 and (t1 is None or s[0] <= t1 + 1e-9)]

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class NavigationSession(_Session):
    """Simulator + move_base + ScenarioClient in one process; goals and poses in the world frame."""

    def __init__(self, world: str = "lab", robot: str = "box", radius: float = 0.3, rtf: float = 0.0,
                 seed: int = 0, range_noise: float = 0.0, launch_file: str = "navigation", tight: bool = False,
                 overrides: tuple[str, ...] = (), foxglove_port: int | None = None, collision_monitor: bool = True,
                 map_name: str = "", max_speed: float | None = None, moving_obstacles: bool = True,
                 slam: bool = False, explore: bool = False, true_obstacles: bool = False):
        if not (math.isfinite(rtf) and rtf >= 0):
            raise ValueError(f"rtf must be >= 0 (0: lockstep), got {rtf!r}")
        self.description = robot_description(robot, radius)
        self.world = load_world(world, robot_radius=self.description.inscribed_radius)
        self.rtf = rtf
        self.map_name, self.slam, self.explore = map_name, slam or explore, explore
        config = load_launch(launch_file, launch_args(world, robot, radius, rtf, tight, foxglove_port=foxglove_port,
                                                      collision_monitor=collision_monitor, map_name=map_name,
                                                      max_speed=max_speed, moving_obstacles=moving_obstacles,
                                                      slam=slam, explore=explore))
        apply_set(config, speed_assignments(config, list(overrides))[0] + list(overrides))
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.nodes: list[Node] = []
        self.client = None
        self.driver: LockstepDriver | None = None
        try:
            with tempfile.TemporaryDirectory(prefix="simplebot_scenario_") as run_dir:  # read as nodes are built
                for spec in config.nodes:
                    exe = resolve_executable(spec.pkg, spec.type)
                    if exe.node_class is None:
                        raise ValueError(f"{spec.full_name}: {exe.module} runs only as its own process")
                    if spec.type == "simulator":
                        spec = dataclasses.replace(spec, parameters={**spec.parameters, "seed": seed,
                                                                     "range_noise_std": float(range_noise)})
                    elif spec.name == "move_base" and rtf == 0:
                        # In lockstep /clock waits for the nodes, not the other way round: no watchdog.
                        spec = dataclasses.replace(spec, parameters={**spec.parameters, "watchdog_timeout": 0.0})
                    elif spec.name == "collision_monitor" and rtf == 0:    # nor a wall-clock guard
                        spec = dataclasses.replace(spec, parameters={**spec.parameters, "scan_silence_timeout": 0.0})
                    elif spec.name == "slam" and rtf == 0:     # every scan, in order: a run repeats
                        spec = dataclasses.replace(spec, parameters={**spec.parameters, "synchronous": True})
                    cls = getattr(importlib.import_module(exe.module), exe.node_class)
                    self.nodes.append(cls(cli_args=ros_args(spec, write_params_file(spec, run_dir)),
                                          use_global_arguments=False, context=self.context))
            self.sim = next(n for n in self.nodes if isinstance(n, SimulatorNode))
            self.move_base = next(n for n in self.nodes if n.get_name() == "move_base")
            if true_obstacles:
                use_true_obstacles(self.move_base, self.sim.sim)
            self.client = ScenarioClient(self.context)
            others = [n for n in self.nodes if n is not self.sim] + [self.client]
            if rtf == 0:
                self.driver = LockstepDriver(self.sim, others)
            else:
                self.executor = SingleThreadedExecutor(context=self.context)
                for node in (self.sim, *others):
                    self.executor.add_node(node)
        except BaseException:
            self.close()
            raise

    @property
    def time(self) -> float:
        return self.sim.sim.sim_time

    def pose(self) -> Pose2D:
        g = self.sim.sim.ground_truth()
        return Pose2D(g.x, g.y, g.yaw)

    def run_until(self, sim_time_s: float | None = None, stop: Callable[[], bool] | None = None,
                  wall_timeout_s: float | None = None) -> bool:
        if self.driver is not None:
            return self.driver.run_until(sim_time_s, stop, wall_timeout_s)
        return super().run_until(sim_time_s, stop, wall_timeout_s)

    def ready(self) -> bool:
        mb = self.move_base
        return (self.client.action.server_is_ready() and mb.global_costmap.is_current()
                and mb.local_costmap.is_current())

    def stats(self) -> SessionStats:
        return SessionStats(self.move_base.events.snapshot(), self.move_base.cycle_stats.snapshot())

    def controller_param(self, name: str, default: float) -> float:
        planner = plugin_namespace(self.move_base.get_parameter("base_local_planner").value)
        full = f"{planner}.{name}"
        return float(self.move_base.get_parameter(full).value) if self.move_base.has_parameter(full) else default

    def close(self) -> None:
        if self.driver is not None:
            self.driver.shutdown()
        if self.executor is not None:
            self.executor.shutdown()
        for node in [*self.nodes, self.client]:
            if node is not None:
                node.destroy_node()
        self.nodes, self.client = [], None
        if self.context.ok():
            rclpy.shutdown(context=self.context)
