"""The launcher's processes as a scenario session: each node in its own process, at real time.

Ground truth, collisions and status come over topics, like any other client's; the launcher's output
(every node's log) goes to ``log_file``, where tests also find the nodes' process ids. RemoteSession is
the same client without the launcher, for a stack that runs elsewhere (another shell or host).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile

import rclpy
from rclpy.executors import SingleThreadedExecutor

from simplebot_description import robot_description
from simplebot_navigation.launch.loader import LaunchConfig, load_launch
from simplebot_navigation.launch.overrides import apply_set, speed_assignments
from simplebot_navigation.move_base.plugins import plugin_namespace
from simplebot_navigation.teb.plugin import TEB_LOCAL_PLANNER
from simplebot_navigation.sim.world import Pose2D
from simplebot_navigation.sim.world_loader import load_world
from simplebot_navigation.scenarios.launch_args import launch_args
from simplebot_navigation.scenarios.session import ScenarioClient, _Session

WRAPPER_LAUNCH = """\
# Written by the scenario runner: the navigation launch file plus the simulator's seed and noise.
from simplebot_navigation.launch.description import Include, Param

LAUNCH = [
    Include(file={launch!r}, args={args!r}),
    Param("/simulator/seed", {seed!r}),
    Param("/simulator/range_noise_std", {noise!r}),
]
"""


class RemoteSession(_Session):
    """A client node for a stack started elsewhere: by the launcher, in another shell, or on another host
    on the same ROS domain (README, "Two hosts"). Goals and poses are in the world frame of ``world``;
    ``launch`` is the configuration move_base was started from, for the goal tolerances. With
    ``namespace`` the client drives the robot under it.
    """

    def __init__(self, world: str = "lab", robot: str = "box", radius: float = 0.3, launch: LaunchConfig | None = None,
                 namespace: str = ""):
        self.description = robot_description(robot, radius)
        self.world = load_world(world, robot_radius=self.description.inscribed_radius)
        self.launch = launch or load_launch("move_base", {"robot": robot})
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.client = ScenarioClient(self.context, namespace)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.client)

    @property
    def time(self) -> float:
        return self.client.get_clock().now().nanoseconds * 1e-9

    def pose(self) -> Pose2D:
        if not self.client.truth:
            return self.world.start
        _, x, y, yaw = self.client.truth[-1]
        return Pose2D(x, y, yaw)

    def ready(self) -> bool:
        return self.client.action.server_is_ready() and bool(self.client.truth)

    def controller_param(self, name: str, default: float) -> float:
        move_base = next(n for n in self.launch.nodes if n.name == "move_base")
        planner = plugin_namespace(str(move_base.parameters.get("base_local_planner", TEB_LOCAL_PLANNER)))
        return float(move_base.parameters.get(f"{planner}.{name}", default))

    def close(self) -> None:
        self.executor.shutdown()
        self.client.destroy_node()
        if self.context.ok():
            rclpy.shutdown(context=self.context)


class ProcessSession(RemoteSession):
    """The launcher's processes (``python -m simplebot_navigation.launch``), a client node here.

    Ground truth, collisions and status come over topics; move_base's counters (replans,
    recoveries, cycle times) are not visible from outside and stay empty. The launcher's output
    goes to ``log_file``. With ``namespace`` the robot runs under it (the launch file's ``namespace``
    argument) and the client drives it there.
    """

    def __init__(self, world: str = "lab", robot: str = "box", radius: float = 0.3, rtf: float = 1.0,
                 seed: int = 0, range_noise: float = 0.0, launch_file: str = "navigation", tight: bool = False,
                 respawn: bool = False, overrides: tuple[str, ...] = (), foxglove_port: int | None = None,
                 namespace: str = "", collision_monitor: bool = True, map_name: str = "",
                 max_speed: float | None = None, moving_obstacles: bool = True):
        if not (math.isfinite(rtf) and rtf > 0):
            raise ValueError(f"separate processes need rtf > 0 (lockstep is single-process), got {rtf!r}")
        self.map_name = map_name
        args = launch_args(world, robot, radius, rtf, tight, respawn, foxglove_port, collision_monitor, map_name,
                           max_speed, moving_obstacles)
        if namespace:  # the launch file's namespace argument: the robot's topics and frames under it
            args["namespace"] = namespace
        launch = load_launch(launch_file, args)
        # What max_speed derives goes to the launcher as --set before the explicit ones: the wrapper launch file
        # below is its top-level file, and it declares no max_speed of its own.
        overrides = tuple(speed_assignments(launch, list(overrides))[0]) + tuple(overrides)
        apply_set(launch, list(overrides))     # checked here, and read by controller_param
        super().__init__(world, robot, radius, launch, namespace)
        self.run_dir = run_dir = tempfile.mkdtemp(prefix="simplebot_scenario_")
        wrapper = os.path.join(run_dir, "scenario_launch.py")
        with open(wrapper, "w", encoding="utf-8") as handle:
            handle.write(WRAPPER_LAUNCH.format(launch=self.launch.file, args=args, seed=seed,
                                               noise=float(range_noise)))
        self.log_file = os.path.join(run_dir, "launch.log")
        with open(self.log_file, "w", encoding="utf-8") as log:
            self.process = subprocess.Popen([sys.executable, "-u", "-m", "simplebot_navigation.launch", wrapper,
                                             *(f"--set={assignment}" for assignment in overrides)],
                                            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                            start_new_session=True)

    def ready(self) -> bool:
        if self.process.poll() is not None:
            raise RuntimeError(f"the launcher ended with exit code {self.process.returncode}; see {self.log_file}")
        return super().ready()

    def node_pid(self, name: str) -> int | None:
        """Process id of a node's latest start, from the launcher's "started /name (...) pid N" line."""
        with open(self.log_file, encoding="utf-8") as log:
            found = re.findall(rf"started /{re.escape(name)} \(.*?\) pid (\d+)", log.read())
        return int(found[-1]) if found else None

    def log_text(self) -> str:
        with open(self.log_file, encoding="utf-8") as log:
            return log.read()

    def close(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGINT)
            try:
                self.process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        if self.process.returncode == 0:      # otherwise its log stays for the error message to point at
            shutil.rmtree(self.run_dir, ignore_errors=True)
        super().close()
