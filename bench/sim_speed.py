"""Simulator speed: the real-time factor the simulator reaches headless, both lidars at 10 Hz.

    .venv/bin/python bench/sim_speed.py [--sim-seconds 20] [--repeats 5] [--quick]

Every runner drives the same run: the lab robot in a world, a controller-like cmd_vel at 10 Hz
(0.3 m/s along the corridor, weaving
without touching the walls), odometry, ground truth and contacts read at 50 Hz, both 683-beam lidars
at 10 Hz, physics at its step rate. A runner returns the wall time of `sim_seconds` of simulated
time; RTF = sim_seconds / wall (>= 10 is the target). Set-up (URDF, world, pybullet, DDS discovery)
is not timed. The ratios to raw are given on wall time and on the CPU time of this process (which
a loaded, shared machine disturbs less).

Columns, side by side in the same run:
  raw       the pure simulator loop (SimplebotSim, no ROS): the limit any node can reach.
            "rays" is the share of its time spent in the lidar ray batches.
  no lidar  the same loop with the ray casting skipped: what physics + drive + odometry cost.
  node      the ROS simulator node in lockstep (real_time_factor 0), driven by advance() as fast as
            it goes, publishing everything (/clock every physics step, odometry, ground truth and
            TF at 50 Hz, both scans, contacts); cmd_vel arrives over DDS from a driver node at 10 Hz.
            No other subscribers: messages are converted and handed to DDS, nobody reads them.
  node+sub  the same with a second process subscribed to both scans (the costmaps' share): the
            scans are serialised and delivered, and that reader competes for the 2 cores.
Target: node >= 10x real time and within 1.5x of raw (ratio column).
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(10 + os.getpid() % 90))

import rclpy  # noqa: E402
from geometry_msgs.msg import Twist  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from simplebot_description import robot_description  # noqa: E402
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode  # noqa: E402
from simplebot_navigation.sim import SimplebotSim, load_world  # noqa: E402

CMD_PERIOD = 0.1
READ_PERIOD = 0.02


@dataclass(frozen=True)
class Config:
    world: str
    body: str
    physics_rate: float
    sim_seconds: float


def make_sim(cfg: Config) -> SimplebotSim:
    description = robot_description(cfg.body)
    return SimplebotSim(load_world(cfg.world, robot_radius=description.inscribed_radius), description,
                        physics_rate=cfg.physics_rate)


def drive(sim: SimplebotSim, sim_seconds: float) -> None:
    """The timed loop: what a simulator node does between its callbacks, minus ROS."""
    next_cmd = 0.0
    while sim.sim_time < sim_seconds - 1e-9:
        if sim.sim_time >= next_cmd - 1e-9:
            sim.set_cmd_vel(0.3, 0.3 * math.cos(sim.sim_time))
            next_cmd += CMD_PERIOD
        sim.step_until(sim.sim_time + READ_PERIOD)
        sim.odometry()
        sim.ground_truth()
        sim.collisions()
        sim.due_scans()


# Seconds spent casting rays in run_raw, per config (the "rays" column).
RAY_SECONDS: dict[Config, list[float]] = {}


class Timed:
    """Wall and CPU seconds (all threads of this process, DDS's included) of the block.

    The objects alive at the start are frozen out of the garbage collector, as the simulator node
    does in its own process: otherwise each full collection (~80 ms with yourdfpy's imports loaded)
    lands in whichever runner happens to trigger it.
    """

    def __enter__(self):
        gc.collect()
        gc.freeze()
        self._wall, self._cpu = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc):
        self.seconds = (time.perf_counter() - self._wall, time.process_time() - self._cpu)
        gc.unfreeze()


def run_raw(cfg: Config) -> tuple[float, float]:
    sim = make_sim(cfg)
    cast, ray_seconds = sim._cast, RAY_SECONDS.setdefault(cfg, [])

    def timed_cast(sensors):
        start = time.perf_counter()
        cast(sensors)
        ray_seconds.append(time.perf_counter() - start)

    sim._cast = timed_cast
    with Timed() as timed:
        drive(sim, cfg.sim_seconds)
    sim.close()
    return timed.seconds


def run_no_lidar(cfg: Config) -> tuple[float, float]:
    sim = make_sim(cfg)
    sim._cast = lambda sensors: None
    with Timed() as timed:
        drive(sim, cfg.sim_seconds)
    sim.close()
    return timed.seconds


SCAN_TOPICS = ("/front_laser/front_scan", "/back_laser/back_scan")
# The node+sub runner lives in its own ROS domain, shared only with its scan reader process.
READER_DOMAIN = 10 + (int(os.environ["ROS_DOMAIN_ID"]) - 10 + 45) % 90
READER = """
import rclpy
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
rclpy.init()
node = rclpy.create_node("scan_reader")
for topic in {topics!r}:
    node.create_subscription(LaserScan, topic, lambda msg: None, qos_profile_sensor_data)
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
"""


def run_node(cfg: Config, domain_id: int | None = None) -> tuple[float, float]:
    """The simulator node stepped by its lockstep driver; cmd_vel comes over DDS."""
    context = rclpy.Context()
    rclpy.init(args=["--ros-args", "--log-level", "warn"], context=context, domain_id=domain_id)
    sim = SimulatorNode(context=context, parameter_overrides=[
        Parameter("world", value=cfg.world), Parameter("robot", value=cfg.body),
        Parameter("physics_rate", value=cfg.physics_rate), Parameter("real_time_factor", value=0.0)])
    driver = Node("bench_driver", context=context)
    cmd_vel = driver.create_publisher(Twist, "/simplebot_controller/cmd_vel", 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(sim)
    readers = 0 if domain_id is None else 1
    deadline = time.monotonic() + 10.0
    while cmd_vel.get_subscription_count() < 1 or any(sim.count_subscribers(t) < readers for t in SCAN_TOPICS):
        if time.monotonic() > deadline:
            raise RuntimeError("simulator node and its peers did not discover each other within 10 s")
        executor.spin_once(timeout_sec=0.05)
    twist = Twist()
    with Timed() as timed:
        while sim.sim.sim_time < cfg.sim_seconds - 1e-9:
            twist.linear.x, twist.angular.z = 0.3, 0.3 * math.cos(sim.sim.sim_time)
            cmd_vel.publish(twist)
            executor.spin_once(timeout_sec=1.0)  # the only callback the node has in lockstep: cmd_vel
            sim.advance(CMD_PERIOD)
    executor.shutdown()
    driver.destroy_node()
    sim.destroy_node()
    rclpy.shutdown(context=context)
    return timed.seconds


def run_node_with_reader(cfg: Config) -> tuple[float, float]:
    return run_node(cfg, READER_DOMAIN)


def start_reader() -> subprocess.Popen:
    env = dict(os.environ, ROS_DOMAIN_ID=str(READER_DOMAIN))
    return subprocess.Popen([sys.executable, "-c", READER.format(topics=SCAN_TOPICS)], env=env)


def stop(process: subprocess.Popen) -> None:
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=5.0)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


RUNNERS = {"raw": run_raw, "no lidar": run_no_lidar, "node": run_node, "node+sub": run_node_with_reader}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sim-seconds", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="5 sim seconds, 3 repeats, 100 Hz only")
    args = parser.parse_args()
    sim_seconds, repeats = (5.0, 3) if args.quick else (args.sim_seconds, args.repeats)
    rows = [("lab", "box", 100.0), ("lab", "round", 100.0)]
    if not args.quick:
        rows.append(("lab", "box", 240.0))

    print(f"{sim_seconds:g} sim s per repeat, {repeats} repeats, interleaved; RTF = sim time / wall time "
          f"(median, and p95 of wall time -> the low RTF)")
    header = f"{'world':8} {'body':6} {'physics':>8} |"
    for name in RUNNERS:
        header += f" {name + ' RTF med':>16} {'p95':>6} |"
    header += f" {'rays':>5} | ratios to raw: median wall / median CPU time"
    print(header)
    print("-" * len(header))
    reader = start_reader()
    try:
        for world, body, rate in rows:
            print_row(Config(world, body, rate, sim_seconds), repeats)
    finally:
        stop(reader)


def print_row(cfg: Config, repeats: int) -> None:
    wall = {name: [] for name in RUNNERS}
    cpu = {name: [] for name in RUNNERS}
    for _ in range(repeats):
        # Interleave the runners so machine load hits all columns alike.
        for name, runner in RUNNERS.items():
            seconds = runner(cfg)
            wall[name].append(seconds[0])
            cpu[name].append(seconds[1])
    line = f"{cfg.world:8} {cfg.body:6} {cfg.physics_rate:>6g}Hz |"
    for name in RUNNERS:
        med, p95 = np.median(wall[name]), np.percentile(wall[name], 95)
        line += f" {cfg.sim_seconds / med:>15.1f}x {cfg.sim_seconds / p95:>5.1f}x |"
    share = sum(RAY_SECONDS[cfg]) / sum(wall["raw"])
    ratios = ", ".join(f"{name} {np.median(wall[name]) / np.median(wall['raw']):.2f}"
                       f" / {np.median(cpu[name]) / np.median(cpu['raw']):.2f}"
                       for name in RUNNERS if name != "raw")
    line += f" {share:>5.0%} | {ratios}"
    print(line, flush=True)


if __name__ == "__main__":
    main()
