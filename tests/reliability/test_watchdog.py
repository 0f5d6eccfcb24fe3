"""The simulator dies in the middle of a goal, or move_base's executor is blocked: the watchdog stops the robot."""

import subprocess
import sys
import threading
import time

import pytest
import rclpy
from geometry_msgs.msg import Twist
from rclpy.executors import SingleThreadedExecutor

from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D


def driving(commands: list[tuple[float, float, float]]) -> bool:
    """The robot is under way: one of the last commands moves it. On a loaded machine the simulator may fall
    behind the wall clock at first (transform timeouts), so the tests wait for this, not for a fixed time."""
    return any(abs(v) > 0.05 for _, v, _ in commands[-10:])


@pytest.mark.timeout(240)
def test_move_base_stops_the_robot_when_the_simulator_dies(capfd):
    with NavigationSession("lab", rtf=1.0) as session:
        session.wait_ready(wall_timeout_s=120.0)
        commands = session.client.record_commands()
        session.send_goal(Pose2D(4.0, 0.0, 0.0, "corridor"))
        session.run_for(30.0, lambda: driving(commands), wall_timeout_s=90.0)
        assert driving(commands), "the robot should be driving"

        session.executor.remove_node(session.sim)       # the simulator dies: no /clock, TF or scans
        session.nodes.remove(session.sim)
        session.sim.destroy_node()
        session.client.status = None
        killed = time.monotonic()
        while time.monotonic() < killed + 1.5:
            session.executor.spin_once(timeout_sec=0.01)
        stops = [t - killed for t, v, w in commands if t > killed and v == 0.0 and w == 0.0]
        assert stops and stops[0] <= 0.5, f"first zero command {stops[:1]} s after the clock stopped"
        last = [c for c in commands if c[0] > killed + 0.5]
        assert last and all(v == 0.0 and w == 0.0 for _, v, w in last)
        err = capfd.readouterr().err
        assert "no control cycle for" in err and "robot stopped" in err
        status = session.client.status
        assert status is not None and status.status_list, "move_base/status goes on while the clock is stopped"



@pytest.mark.timeout(240)
def test_a_goal_waiting_for_a_dead_clock_is_aborted_after_max_wait(capfd):
    with NavigationSession("lab", rtf=1.0) as session:
        session.wait_ready(wall_timeout_s=120.0)
        session.move_base.cfg.max_wait = 1.0          # 30 s by default
        run = session.send_goal(Pose2D(4.0, 0.0, 0.0, "corridor"))
        session.run_for(2.0, wall_timeout_s=60.0)
        session.executor.remove_node(session.sim)
        session.nodes.remove(session.sim)
        session.sim.destroy_node()
        end = time.monotonic() + 5.0
        while not run.done and time.monotonic() < end:
            session.executor.spin_once(timeout_sec=0.01)
        assert run.status == "ABORTED"
        err = capfd.readouterr().err
        assert "Aborting the goal: no control cycle for" in err and "(is /clock running?) (max_wait 1 s)" in err


class CommandObserver:
    """move_base's commands (cmd_vel_nav, to the collision monitor) as they arrive, heard by a node of the session's
    context with an executor and a thread of its own: it hears move_base while the session's executor (the test's
    thread, the monitor's too) is blocked. One context is one DDS participant: nothing to discover (a second
    participant, on a loaded CI machine, once matched no publisher in 60 s)."""

    def __init__(self, context):
        self.node = rclpy.create_node("command_observer", context=context)
        self.commands: list[tuple[float, float, float]] = []
        self.node.create_subscription(Twist, "/cmd_vel_nav", lambda m: self.commands.append(
            (time.monotonic(), m.linear.x, m.angular.z)), 50)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.executor.shutdown()
        self.thread.join(timeout=5.0)
        self.node.destroy_node()


@pytest.mark.timeout(240)
def test_move_base_stops_the_robot_while_its_executor_is_blocked_on_a_loaded_machine():
    """Nothing of move_base's executor runs (a callback that takes seconds), and two busy loops load the
    machine: the watchdog's own thread still sends zero velocity within half a second. The load starts once the
    robot drives: a real-time session on a starved core may not reach that at all, and the claim is about the
    watchdog, not about the stack's speed under load."""
    busy: list[subprocess.Popen] = []
    try:
        with NavigationSession("lab", rtf=1.0) as session:
            observer = CommandObserver(session.context)
            try:
                session.wait_ready(wall_timeout_s=120.0)
                session.send_goal(Pose2D(4.0, 0.0, 0.0, "corridor"))
                session.run_for(30.0, lambda: driving(observer.commands), wall_timeout_s=90.0)
                assert driving(observer.commands), "the robot should be driving"
                busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
                session.run_for(1.0, wall_timeout_s=10.0)    # the loops are running when the executor blocks
                blocked = time.monotonic()
                time.sleep(1.5)   # the test's thread is the session's executor: every callback waits
                stops = [t - blocked for t, v, w in observer.commands if t > blocked and v == 0.0 and w == 0.0]
                late = [(v, w) for t, v, w in observer.commands if t > blocked + 0.5 and (v != 0.0 or w != 0.0)]
            finally:
                observer.close()
    finally:
        for process in busy:
            process.kill()
            process.wait()
    assert stops and stops[0] <= 0.5, f"first zero command {stops[:1]} s after the executor blocked"
    assert not late, f"commands other than zero while the executor was blocked: {late[:3]}"
