"""The simulator node: SimplebotSim behind the topics the lab's Gazebo set-up had.

Simulated time is the clock of every other node (/clock). In its own process the
node steps the simulation against the wall clock at ``real_time_factor``; with
``real_time_factor: 0`` it does not step by itself and a lockstep driver calls
``advance()`` (single-process runs, tests and the scenario runner: docs/design.md §3).

/clock goes out on every physics step, so sim-time timers fire at the physics resolution
(10 ms) rather than in bursts; it is about 4 % of the node's stepping cost (bench/sim_speed.py).

At real time the steps run in a thread of their own, paced by the wall clock, and the executor
only wakes for cmd_vel: an executor round per 10 ms tick cost more than the physics step it ran.
The node is the clock, so it never follows /clock itself (use_sim_time is turned off).
"""

from __future__ import annotations

import io
import math
import sys
import threading
import time

import numpy as np
import yourdfpy
from rclpy.clock import Clock, ClockType
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock as ClockMsg

from simplebot_description import robot_description
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import declare_checked, refuse_unknown_parameters
from simplebot_navigation.ros.simulator.moving_markers import MovingObstacleMarkers
from simplebot_navigation.ros.simulator.simulator_faults import SimulatorFaults
from simplebot_navigation.ros.simulator.simulator_robot import SimulatedRobotIO, set_stamp
from simplebot_navigation.ros.tf import StaticTransformBroadcaster, TransformBroadcaster
from simplebot_navigation.sim.diff_drive import OdomNoise, drive_for
from simplebot_navigation.sim.simulator import SimplebotSim
from simplebot_navigation.sim.starts import robot_starts
from simplebot_navigation.sim.world_loader import load_world

# Wall-clock ticks come once per physics step but no faster than this: a tick costs about as much
# as a physics step, so at high real-time factors each tick steps several times.
MIN_WALL_TICK_S = 0.005
MAX_LAG_S = 0.5
#: how often /sim/moving_obstacles goes out, as the lidars' scans do
MARKER_RATE_HZ = 10.0
# Launch files and `-p name:=2` give whole numbers as integers; the numeric parameters take both.
# ``namespaces``: one robot per space-separated name ("robot1 robot2"); empty: one robot, no namespace.
# ``starts``: "x,y,yaw;x,y,yaw;..." for them; empty: the world's starts (one robot: its start).
# ``odom_scale_std``/``odom_speed_std``: encoder errors (relative, sim/diff_drive.py OdomNoise), off by default.
# ``map_to_odom``: namespaced robots' odom frames hang from a static ``map`` at their starts; false where a
# localizer (amcl) publishes map -> odom itself.
# ``max_speed`` (declared apart: a number, or "", the launch argument's default): the top speed asked of the
# drive in m/s (sim/diff_drive.py drive_for); "" keeps the lab's drive.
PARAMETERS = {"world": "lab", "robot": "box", "radius": 0.3, "real_time_factor": 1.0, "physics_rate": 100.0,
              "odom_rate": 50.0, "seed": 0, "range_noise_std": 0.0, "namespaces": "", "starts": "",
              "odom_scale_std": 0.0, "odom_speed_std": 0.0, "map_to_odom": True}


def _quaternion_from_matrix(m: np.ndarray) -> tuple[float, float, float, float]:
    w = math.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    x = math.copysign(math.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2.0, m[2, 1] - m[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2.0, m[0, 2] - m[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2.0, m[1, 0] - m[0, 1])
    return float(x), float(y), float(z), float(w)


class SimulatorNode(SetUpNode):
    def __init__(self, **kwargs):
        super().__init__("simulator", **kwargs)

    def _set_up(self) -> None:
        if self.get_parameter("use_sim_time").value:
            self.set_parameters([Parameter("use_sim_time", value=False)])
        p = self._checked_parameters()
        self.description = robot_description(p["robot"], p["radius"])
        try:
            drive = drive_for(self.description, None if p["max_speed"] == "" else p["max_speed"])
        except ValueError as err:
            raise ValueError(f"parameter 'max_speed': {err}") from err
        try:
            self.world = load_world(p["world"], robot_radius=self.description.inscribed_radius)
        except (ValueError, FileNotFoundError) as err:
            raise ValueError(f"parameter 'world': {err}") from err
        for warning in self.world.warnings:
            self.get_logger().warn(warning)
        namespaces = p["namespaces"].split() or [""]
        try:
            starts = robot_starts(self.world, [ns or "simplebot" for ns in namespaces], p["starts"],
                                  self.description)
        except ValueError as err:
            raise ValueError(f"parameter 'starts': {err}") from err
        odom_noise = OdomNoise(scale_std=p["odom_scale_std"], speed_std=p["odom_speed_std"])
        self.sim = SimplebotSim(self.world, self.description, physics_rate=p["physics_rate"], seed=p["seed"],
                                drive=drive, range_noise_std=p["range_noise_std"], odom_noise=odom_noise,
                                starts=starts)
        self.rtf = p["real_time_factor"]
        self._odom_every = max(1, round(p["physics_rate"] / p["odom_rate"]))
        self._markers_every = max(1, round(p["physics_rate"] / MARKER_RATE_HZ))

        self.clock_pub = self.create_publisher(ClockMsg, "/clock", 10)
        wheel_joints = self._wheel_geometry()
        self.robots = [SimulatedRobotIO(self, self.sim, i, ns, wheel_joints) for i, ns in enumerate(namespaces)]
        self.faults = SimulatorFaults(self, self.description.scans)
        self.moving_markers = MovingObstacleMarkers(self, self.sim, namespaces != [""], starts[0])
        refuse_unknown_parameters(self)
        self.add_on_set_parameters_callback(self._refuse_restart_only)
        self.tf_broadcaster = TransformBroadcaster(self)
        StaticTransformBroadcaster(self).send_transform([tf for robot in self.robots
                                                         for tf in robot.static_transforms(p["map_to_odom"])])
        self._clock_msg = ClockMsg()
        self._steps = 0
        self._stepper: threading.Thread | None = None
        self._stop = threading.Event()
        self._stepper_error: BaseException | None = None
        if self.rtf > 0:
            self._stepper_failed = self.create_guard_condition(self._raise_stepper_error)
            # The stepping thread starts with the first executor round: time until spinning starts is not lag.
            self._start_timer = self.create_timer(0.0, self._start_stepping,
                                                  clock=Clock(clock_type=ClockType.STEADY_TIME))
        robots = ", ".join(f"{'/' + ns + ' ' if ns else ''}at ({start.x:.2f}, {start.y:.2f}, yaw {start.yaw:.2f})"
                           for ns, start in zip(namespaces, starts))
        top_speed = drive.max_wheel_speed * self.description.wheel_radius
        self.get_logger().info(
            f"world '{self.world.name}', {self.description.body} robot {robots}, top speed {top_speed:g} m/s, "
            f"physics {p['physics_rate']:g} Hz, "
            + (f"real-time factor {self.rtf:g}" if self.rtf > 0 else "lockstep (stepped by its driver)"))

    def _refuse_restart_only(self, params: list[Parameter]) -> SetParametersResult:
        """The world, the robots and the stepping are built from these at start-up: a change would answer
        "successful" and do nothing. Only the faults change while running."""
        fixed = [param.name for param in params
                 if param.name in PARAMETERS or param.name in ("max_speed", "use_sim_time")]
        if fixed:
            return SetParametersResult(successful=False, reason=f"{', '.join(fixed)}: requires restart (the simulator "
                                                                f"reads {'it' if len(fixed) == 1 else 'them'} at start-up only)")
        return SetParametersResult(successful=True)

    def _checked_parameters(self) -> dict:
        """Declared parameters, checked before anything is built (pybullet, publishers)."""
        values = declare_checked(self, PARAMETERS, positive=("physics_rate", "odom_rate"))
        values["max_speed"] = self.declare_parameter("max_speed", "", ParameterDescriptor(dynamic_typing=True)).value
        if not (math.isfinite(values["real_time_factor"]) and values["real_time_factor"] >= 0):
            raise ValueError(f"parameter 'real_time_factor' must be >= 0 (0: stepped by a driver), "
                             f"got {values['real_time_factor']!r}")
        for name in ("odom_scale_std", "odom_speed_std"):
            if values[name] < 0:
                raise ValueError(f"parameter {name!r} must be >= 0 (a relative standard deviation), "
                                 f"got {values[name]!r}")
        return values

    # -- stepping -------------------------------------------------------------------------------
    def advance(self, duration: float) -> None:
        """Step the simulation by duration seconds, publishing everything that falls due."""
        end = self.sim.sim_time + duration
        while self.sim.sim_time + self.sim.dt <= end + 1e-9:
            self._step()

    def _start_stepping(self) -> None:
        self.destroy_timer(self._start_timer)
        self._stepper = threading.Thread(target=self._step_against_wall_clock, name="simulator steps", daemon=True)
        self._stepper.start()

    def _step_against_wall_clock(self) -> None:
        """Ticks once per physics step (at most every MIN_WALL_TICK_S), each advancing to rtf x wall time."""
        period = max(self.sim.dt / self.rtf, MIN_WALL_TICK_S)
        wall_start = next_tick = time.monotonic()
        sim_start = self.sim.sim_time
        try:
            while not self._stop.wait(max(0.0, next_tick - time.monotonic())):
                now = time.monotonic()
                next_tick = max(next_tick + period, now)  # late ticks are skipped, as a timer's are
                target = sim_start + (now - wall_start) * self.rtf
                lag = target - self.sim.sim_time
                if lag > MAX_LAG_S:
                    self.get_logger().warn(f"cannot keep real_time_factor {self.rtf:g}: simulation is {lag:.2f} s "
                                           "behind; slowing down", throttle_duration_sec=5.0)
                    wall_start, sim_start = now, self.sim.sim_time
                    target = self.sim.sim_time + self.sim.dt
                self.advance(target - self.sim.sim_time)
        except BaseException as err:  # handed to the executor, whose spin then raises it
            if not self._stop.is_set() and self.context.ok():
                self._stepper_error = err
                self._stepper_failed.trigger()

    def _raise_stepper_error(self) -> None:
        raise self._stepper_error

    def _step(self) -> None:
        self.sim.step()
        self._steps += 1
        set_stamp(self._clock_msg.clock, self.sim.sim_time)
        self.clock_pub.publish(self._clock_msg)
        odometry_due = self._steps % self._odom_every == 0
        transforms = []
        for robot in self.robots:
            if odometry_due:
                transforms += robot.publish_odometry(self._clock_msg.clock, self.faults.odometry_dropout)
            robot.publish_scans(self.faults.drops_scan)
            robot.publish_collisions_if_new()
        if self._steps % self._markers_every == 0:
            self.moving_markers.publish()
        if odometry_due:
            due = self.faults.transforms_due(self.sim.sim_time, transforms)
            if due:
                self.tf_broadcaster.send_transform(due)

    def _wheel_geometry(self) -> dict:
        """joint -> (parent, child, origin as (x, y, z, qx, qy, qz, qw), unit axis) of the wheel joints."""
        urdf = yourdfpy.URDF.load(io.StringIO(self.description.urdf), build_scene_graph=False,
                                  load_meshes=False)
        joints = {}
        for name, j in urdf.joint_map.items():
            if j.type in ("continuous", "revolute"):
                origin = j.origin if j.origin is not None else np.eye(4)
                axis = np.asarray(j.axis, float)
                joints[name] = (j.parent, j.child, (*(float(v) for v in origin[:3, 3]),
                                                    *_quaternion_from_matrix(origin[:3, :3])),
                                tuple(float(v) for v in axis / np.linalg.norm(axis)))
        return joints

    def destroy_node(self) -> None:
        stop, stepper = getattr(self, "_stop", None), getattr(self, "_stepper", None)
        if stepper is not None:
            stop.set()
            stepper.join()
        sim = getattr(self, "sim", None)
        if sim is not None:
            sim.close()
        super().destroy_node()


def _build_own_process_simulator() -> SimulatorNode:
    node = SimulatorNode()
    if node.rtf == 0:
        node.destroy_node()
        raise ValueError("parameter 'real_time_factor' is 0 (lockstep), but in its own process nothing "
                         "steps the simulator: run the nodes in one process (launcher --single-process)")
    return node


def main(args=None) -> int:
    return run_node("simulator", _build_own_process_simulator, args, (ValueError, FileNotFoundError))

if __name__ == "__main__":
    sys.exit(main())
