"""Lockstep: the simulator advances only while every other node of the process is idle (docs/design.md §3).

One SingleThreadedExecutor holds the simulator (``real_time_factor: 0``) and the nodes it drives.
Each round advances the physics to the next event and then runs callbacks until the graph is idle.
An event is a step at which the simulator publishes more than /clock (odometry, TF, scans) or at
which a sim-time timer of some node falls due; the steps in between would only update the nodes'
clocks (whose /clock subscriptions keep just the newest message), so skipping their rounds changes
nothing a node can see, and saves most of the executor's wait-set builds.

Idle is exact, not a guess from a quiet period: rmw_fastrtps delivers between the nodes of one
process synchronously, inside ``publish()``, so a message that any callback sent is already waiting
when the next wait set is built. A zero-timeout wait that finds nothing new therefore means nothing
is in flight. Pending coroutine tasks (an action server's execute callback awaiting its result) are
resumed by the executor on every wait; one whose coroutine stays suspended at the same point made no
progress, and a pass with nothing else ends the round.

The executor visits nodes in the order they were added (rclpy keeps them in a set, whose order
changes from run to run), so with the same seed a run repeats callback for callback.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from typing import Callable, Iterable, Iterator

from rclpy.clock import ClockType
from rclpy.executors import SingleThreadedExecutor, TimeoutException
from rclpy.node import Node

from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode

MAX_CALLBACKS_PER_ROUND = 20000
_NEW = object()


class LockstepError(TimeoutError):
    """Time could not advance as asked: the graph never became idle, or a wall-clock guard expired.

    The message says at which sim time and, for a busy graph, which callbacks kept it busy."""


class _OrderedExecutor(SingleThreadedExecutor):
    """A SingleThreadedExecutor that visits its nodes in the order they were added."""

    def __init__(self, *, context=None):
        super().__init__(context=context)
        self._order: list[Node] = []

    def add_node(self, node: Node) -> bool:
        added = super().add_node(node)
        if added:
            self._order.append(node)
        return added

    def remove_node(self, node: Node) -> None:
        super().remove_node(node)
        if node in self._order:
            self._order.remove(node)

    def get_nodes(self) -> list[Node]:
        with self._nodes_lock:
            return [node for node in self._order if node in self._nodes]


class LockstepDriver:
    """Step a lockstep simulator and the nodes around it: ``LockstepDriver(sim_node, [move_base])``.

    ``run_until(t, stop=...)`` advances simulated time to t (or until ``stop()`` is true), never
    faster than the nodes' callbacks; ``wall_timeout_s`` turns a hang into a LockstepError.
    """

    def __init__(self, simulator: SimulatorNode, nodes: Iterable[Node] = (), *,
                 max_callbacks_per_round: int = MAX_CALLBACKS_PER_ROUND):
        if simulator.rtf != 0:
            raise ValueError(f"lockstep needs the simulator with real_time_factor 0, it has {simulator.rtf:g}")
        self.simulator = simulator
        self.max_callbacks_per_round = max_callbacks_per_round
        self.executor = _OrderedExecutor(context=simulator.context)
        self._pending: dict = {}  # coroutine task -> where it is suspended
        rate = simulator.get_parameter("physics_rate").value
        odom_every = max(1, round(rate / simulator.get_parameter("odom_rate").value))
        # Steps at which the simulator publishes odometry/TF or a scan (as SimulatorNode._step does).
        self._publication_periods = [odom_every] + [max(1, round(rate / scan.update_rate))
                                                    for scan in simulator.description.scans.values()]
        self._observers: list[Callable[[], None]] = []
        self.rounds = 0
        self.callbacks = 0
        for node in (simulator, *nodes):
            self.add_node(node)
        self.settle()

    @classmethod
    def of(cls, nodes: Iterable[Node]) -> LockstepDriver | None:
        """A driver for these nodes if one of them is a lockstep simulator, else None."""
        nodes = list(nodes)
        simulator = next((n for n in nodes if isinstance(n, SimulatorNode) and n.rtf == 0), None)
        if simulator is None:
            return None
        return cls(simulator, [n for n in nodes if n is not simulator])

    def add_node(self, node: Node) -> None:
        if node.context is not self.simulator.context:
            raise ValueError(f"node {node.get_fully_qualified_name()} is in another rclpy context than the "
                             "simulator; lockstep needs one context")
        self.executor.add_node(node)

    def remove_node(self, node: Node) -> None:
        self.executor.remove_node(node)

    def on_step(self, observer: Callable[[], None]) -> None:
        """Call observer() after every step, once the graph is idle (to record ground truth, say)."""
        self._observers.append(observer)

    @property
    def time(self) -> float:
        """Simulated seconds."""
        return self.simulator.sim.sim_time

    @property
    def dt(self) -> float:
        return self.simulator.sim.dt

    # -- stepping ---------------------------------------------------------------------------------
    def step(self) -> None:
        """Advance to the next event (at least one physics step), then run every callback it caused."""
        self.simulator.advance(self._steps_to_next_event() * self.dt)
        self.rounds += 1
        self.settle()
        for observer in self._observers:
            observer()

    def run_until(self, sim_time_s: float | None = None, stop: Callable[[], bool] | None = None,
                  wall_timeout_s: float | None = None) -> bool:
        """Step until simulated time reaches sim_time_s or stop() is true (checked after every round).

        Returns True if stop() ended the run, False if sim_time_s was reached. Raises LockstepError
        when wall_timeout_s wall-clock seconds pass first.
        """
        if sim_time_s is None and stop is None and wall_timeout_s is None:
            raise ValueError("run_until needs sim_time_s, stop or wall_timeout_s (spin() runs forever)")
        if sim_time_s is not None and not math.isfinite(sim_time_s):
            raise ValueError(f"sim_time_s must be finite, got {sim_time_s!r}")
        deadline = None if wall_timeout_s is None else time.monotonic() + wall_timeout_s
        self.settle()
        while True:
            if stop is not None and stop():
                return True
            if sim_time_s is not None and self.time >= sim_time_s - self.dt / 2:
                return False
            if deadline is not None and time.monotonic() > deadline:
                target = f"sim time {sim_time_s:.2f} s" if sim_time_s is not None else "the stop condition"
                raise LockstepError(f"wall-clock guard of {wall_timeout_s:g} s expired at sim time "
                                    f"{self.time:.2f} s before reaching {target}")
            self.step()

    def run_for(self, duration_s: float, stop: Callable[[], bool] | None = None,
                wall_timeout_s: float | None = None) -> bool:
        return self.run_until(self.time + duration_s, stop, wall_timeout_s)

    def spin(self) -> None:
        """Run as fast as the nodes allow until the context shuts down (the --rtf 0 launcher)."""
        context = self.simulator.context
        while context.ok():
            self.step()

    def _steps_to_next_event(self) -> int:
        """Physics steps until the simulator publishes more than /clock or a sim-time timer falls due."""
        steps = round(self.time / self.dt)
        n = min(period - steps % period for period in self._publication_periods)
        dt_ns = self.dt * 1e9
        for node in self.executor.get_nodes():
            for timer in node.timers:
                clock = timer.clock
                if clock.clock_type != ClockType.ROS_TIME or not getattr(clock, "ros_time_is_active", False):
                    continue  # a wall-clock timer fires whenever its time comes during a round
                until = timer.time_until_next_call()
                if until is not None:  # None: cancelled
                    n = min(n, math.ceil(until / dt_ns - 1e-6))
        return max(1, n)

    # -- idle detection ---------------------------------------------------------------------------
    def settle(self) -> int:
        """Run callbacks until the graph is idle; returns how many ran."""
        ran = 0
        busy: Counter = Counter()
        progressed = True
        while progressed:
            progressed = False
            for handler, entity, node in self._one_pass():
                before = self._pending.get(handler, _NEW)
                handler()
                if handler.exception() is not None:
                    raise handler.exception()
                ran += 1
                if handler.done():
                    self._pending.pop(handler, None)
                else:
                    where = _suspended_at(handler)
                    self._pending[handler] = where
                    if where == before:
                        continue  # resumed, still waiting at the same await
                progressed = True
                busy[_describe(entity, node)] += 1
                if ran > self.max_callbacks_per_round:
                    top = ", ".join(f"{name} x{count}" for name, count in busy.most_common(3))
                    raise LockstepError(f"the nodes are still busy after {ran} callbacks at sim time "
                                        f"{self.time:.3f} s (a publish/subscribe loop?); busiest: {top}")
        self._pending = {task: where for task, where in self._pending.items() if not task.done()}
        self.callbacks += ran
        return ran

    def _one_pass(self) -> Iterator[tuple]:
        """Everything ready at one zero-timeout wait (plus the pending tasks rclpy resumes first)."""
        while True:
            try:
                yield self.executor.wait_for_ready_callbacks(timeout_sec=0.0)
            except TimeoutException:
                return

    def shutdown(self) -> None:
        self.executor.shutdown()


def _suspended_at(task) -> tuple:
    """The frames and instruction offsets down a pending task's await chain: equal means no progress.

    rclpy's Task keeps its coroutine in ``_handler``; without it every resume looks the same (quiet).
    """
    where = []
    awaited = getattr(task, "_handler", None)
    while awaited is not None:
        frame = getattr(awaited, "cr_frame", None) or getattr(awaited, "gi_frame", None)
        if frame is None:
            break
        where.append((id(frame), frame.f_lasti))
        awaited = getattr(awaited, "cr_await", None) or getattr(awaited, "gi_yieldfrom", None)
    return tuple(where)


def _describe(entity, node) -> str:
    where = node.get_fully_qualified_name() if node is not None else "executor"
    what = getattr(entity, "topic_name", None) or getattr(entity, "srv_name", None) or type(entity).__name__
    return f"{where}:{what}"
