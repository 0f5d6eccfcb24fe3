"""The lockstep driver: sim time moves only through it, timers keep their sim rate, runs repeat exactly."""

import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import Twist
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rclpy.task import Future
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Int32

from simplebot_navigation.ros.simulator import lockstep
from simplebot_navigation.ros.simulator.lockstep import LockstepDriver, LockstepError
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from tests.conftest import fresh_context

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SIM_TIME = [Parameter("use_sim_time", value=True)]


@pytest.fixture
def context():
    yield from fresh_context()


def simulator(context, **params) -> SimulatorNode:
    values = {"world": "lab", "real_time_factor": 0.0, **params}
    return SimulatorNode(context=context, parameter_overrides=SIM_TIME + [Parameter(k, value=v)
                                                                          for k, v in values.items()])


class Ticker(Node):
    """A sim-time timer (10 Hz by default) whose callback takes `work_s` of wall time."""

    def __init__(self, context, work_s=0.0, period=0.1):
        super().__init__("ticker", context=context, parameter_overrides=SIM_TIME)
        self.stamps: list[float] = []
        self.work_s = work_s
        self.create_timer(period, self._tick)

    def _tick(self):
        self.stamps.append(self.get_clock().now().nanoseconds / 1e9)
        time.sleep(self.work_s)


class Wanderer(Node):
    """Closed loop on the noisy front scan at 20 Hz: turn away from the nearer side, slow down near walls."""

    def __init__(self, context):
        super().__init__("wanderer", context=context, parameter_overrides=SIM_TIME)
        self.scan = None
        self.cmd = self.create_publisher(Twist, "/simplebot_controller/cmd_vel", 10)
        self.create_subscription(LaserScan, "/front_laser/front_scan", self._on_scan, qos_profile_sensor_data)
        self.create_timer(0.05, self._control)

    def _on_scan(self, msg):
        self.scan = np.asarray(msg.ranges)

    def _control(self):
        if self.scan is None:
            return
        half = len(self.scan) // 2
        left, right = np.nanmin(self.scan[half:]), np.nanmin(self.scan[:half])
        msg = Twist()
        msg.linear.x = float(min(0.6, 0.4 * min(left, right)))
        msg.angular.z = float(np.clip(1.5 * (left - right), -1.0, 1.0))
        self.cmd.publish(msg)


def drive(seed: int, seconds: float = 6.0) -> np.ndarray:
    """Ground-truth trajectory (one row per physics step) of the Wanderer with this lidar noise seed."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    sim = simulator(ctx, seed=seed, range_noise_std=0.02)
    wanderer = Wanderer(ctx)
    driver = LockstepDriver(sim, [wanderer])
    poses = []

    def record():
        truth = sim.sim.ground_truth()
        poses.append((truth.stamp, truth.x, truth.y, truth.yaw))

    driver.on_step(record)
    try:
        driver.run_until(seconds)
    finally:
        driver.shutdown()
        wanderer.destroy_node()
        sim.destroy_node()
        rclpy.shutdown(context=ctx)
    return np.array(poses)


def test_same_seed_same_trajectory_other_seed_another():
    first, second, other = drive(seed=3), drive(seed=3), drive(seed=4)
    # One round per event: the 300 odometry steps (50 Hz) and the 60 ticks of the 20 Hz controller
    # that fall between them (0.05, 0.15, ...).
    assert len(first) == len(second) == 360
    travelled = np.sum(np.hypot(*np.diff(first[:, 1:3], axis=0).T))
    assert travelled > 1.0  # it really drove
    np.testing.assert_array_equal(first, second)
    assert np.max(np.abs(first[:, 1:3] - other[:, 1:3])) > 1e-6


def test_sim_time_moves_only_through_the_driver(context):
    sim, ticker = simulator(context), Ticker(context)
    driver = LockstepDriver(sim, [ticker])
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        driver.settle()
    assert driver.time == 0.0
    assert ticker.get_clock().now().nanoseconds == 0
    assert driver.run_for(0.5) is False
    assert driver.time == pytest.approx(0.5)
    assert ticker.get_clock().now().nanoseconds == 500_000_000
    assert ticker.stamps == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5])
    driver.shutdown()


def test_a_10hz_timer_fires_10_times_per_sim_second_however_slow_its_callback(context):
    # Each callback takes 0.12 s of wall time, more than its 0.1 s period.
    sim, ticker = simulator(context), Ticker(context, work_s=0.12)
    driver = LockstepDriver(sim, [ticker])
    start = time.monotonic()
    driver.run_until(1.0)
    assert time.monotonic() - start > 1.0
    assert ticker.stamps == pytest.approx([0.1 * k for k in range(1, 11)])
    driver.shutdown()


def test_rounds_skip_clock_only_steps_but_never_a_timer(context):
    # 0.07 s is no multiple of the 0.02 s odometry period: the timer's own steps must be rounds too.
    sim, ticker = simulator(context), Ticker(context, period=0.07)
    driver = LockstepDriver(sim, [ticker])
    driver.run_until(0.7)
    assert ticker.stamps == pytest.approx([0.07 * k for k in range(1, 11)])
    # 35 odometry steps + the 5 timer steps between them (0.07, 0.21, ...), not 70 physics steps.
    assert driver.rounds == 40
    driver.shutdown()


def test_a_command_sent_by_a_timer_reaches_the_simulation_in_the_same_step(context):
    sim, wanderer = simulator(context), Wanderer(context)
    received = []
    set_cmd_vel = sim.sim.set_cmd_vel
    sim.sim.set_cmd_vel = lambda v, w, now=None, robot=0: (received.append(sim.sim.sim_time),
                                                           set_cmd_vel(v, w, now, robot))
    driver = LockstepDriver(sim, [wanderer])
    driver.run_until(0.5)
    # The first scan comes at 0.1 s; from then on every 0.05 s tick commands at its own sim time.
    assert received == pytest.approx([0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5])
    driver.shutdown()


class Waiter(Node):
    """A task (as an action server runs its execute callback) that awaits a future a timer completes."""

    def __init__(self, context):
        super().__init__("waiter", context=context, parameter_overrides=SIM_TIME)
        self.done = Future()
        self.resumed_at = None
        self.create_subscription(Int32, "/start", self._on_start, 10)
        self.start_pub = self.create_publisher(Int32, "/start", 10)
        self.create_timer(0.5, self._finish)

    def _on_start(self, _msg):
        self.executor.create_task(self._wait)

    async def _wait(self):
        await self.done
        self.resumed_at = self.get_clock().now().nanoseconds / 1e9

    def _finish(self):
        if not self.done.done():
            self.done.set_result(True)


def test_the_kept_wait_set_gives_the_trajectory_of_rclpys_own_pass(monkeypatch):
    kept = drive(seed=3)
    monkeypatch.setattr(lockstep, "rclpy_differences", lambda: ("rclpy's own pass, for comparison",))
    np.testing.assert_array_equal(kept, drive(seed=3))


def test_a_pending_coroutine_does_not_stall_the_steps(context):
    sim, waiter = simulator(context), Waiter(context)
    driver = LockstepDriver(sim, [waiter])
    waiter.start_pub.publish(Int32(data=1))
    driver.run_until(1.0, wall_timeout_s=30.0)
    assert driver.time == pytest.approx(1.0)
    assert waiter.resumed_at == pytest.approx(0.5)
    driver.shutdown()


def test_stop_condition_ends_the_run_at_the_first_step_it_holds(context):
    sim, ticker = simulator(context), Ticker(context)
    driver = LockstepDriver(sim, [ticker])
    assert driver.run_until(5.0, stop=lambda: len(ticker.stamps) == 3) is True
    assert driver.time == pytest.approx(0.3)
    driver.shutdown()


def test_wall_clock_guard(context):
    sim, ticker = simulator(context), Ticker(context, work_s=0.05)
    driver = LockstepDriver(sim, [ticker])
    with pytest.raises(LockstepError, match=r"wall-clock guard of 0.2 s expired at sim time .* before reaching "
                                            r"sim time 100.00 s"):
        driver.run_until(100.0, wall_timeout_s=0.2)
    driver.shutdown()


class Echo(Node):
    def __init__(self, context):
        super().__init__("echo", context=context)
        self.pub = self.create_publisher(Int32, "/ping", 10)
        self.create_subscription(Int32, "/ping", lambda m: self.pub.publish(Int32(data=m.data + 1)), 10)


def test_a_node_that_never_goes_idle_is_named(context):
    sim, echo = simulator(context), Echo(context)
    driver = LockstepDriver(sim, [echo], max_callbacks_per_round=500)
    echo.pub.publish(Int32(data=0))
    with pytest.raises(LockstepError, match=r"still busy after 501 callbacks at sim time 0.020 s .* busiest: "
                                            r"/echo:/ping x"):
        driver.step()
    driver.shutdown()


def test_rejects_a_free_running_simulator_and_bad_arguments(context):
    sim = simulator(context, real_time_factor=1.0)
    with pytest.raises(ValueError, match="real_time_factor 0, it has 1"):
        LockstepDriver(sim)
    sim.destroy_node()
    driver = LockstepDriver(simulator(context))
    with pytest.raises(ValueError, match="run_until needs sim_time_s, stop or wall_timeout_s"):
        driver.run_until()
    with pytest.raises(ValueError, match="sim_time_s must be finite"):
        driver.run_until(math.inf)
    driver.shutdown()


def test_single_process_launch_with_rtf_0_runs_in_lockstep():
    env = dict(os.environ, PYTHONPATH=REPO)
    proc = subprocess.Popen([sys.executable, "-m", "simplebot_navigation.launch", "navigation", "--single-process",
                             "--rtf", "0", "--world", "empty"], cwd=REPO, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    lines = []
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            lines.append(line.rstrip())
            if "lockstep: the simulator steps" in line:
                break
        assert any("lockstep: the simulator steps" in line for line in lines), "\n".join(lines)
        time.sleep(1.0)
        assert proc.poll() is None, "\n".join(lines)
        os.killpg(proc.pid, signal.SIGINT)
        rest, _ = proc.communicate(timeout=20)
        assert proc.returncode == 0, "\n".join(lines[-5:]) + "\n" + rest
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
