"""Lockstep: the simulator advances only while every other node of the process is idle (DESIGN §3).

One SingleThreadedExecutor holds the simulator (``real_time_factor: 0``) and the nodes it drives.
Each round steps the physics once (the simulator publishes /clock every step, so no step can be
skipped without some node seeing time jump past a timer) and then runs callbacks until the graph is
idle. Idle is exact, not a guess from a quiet period: rmw_fastrtps delivers between the nodes of one
process synchronously, inside ``publish()``, so a message that any callback sent is already waiting
when the next wait set is built. A zero-timeout wait that finds nothing new therefore means nothing
is in flight. Pending coroutine tasks (an action server's execute callback awaiting its result) are
resumed by the executor on every wait without making progress; a pass that only resumes them counts
as quiet, and two such passes in a row (the second lets a task that another one unblocked finish)
end the round.

The executor visits nodes in the order they were added (rclpy keeps them in a set, whose order
changes from run to run), so with the same seed a run repeats callback for callback.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from typing import Callable, Iterable, Iterator

from rclpy.executors import SingleThreadedExecutor, TimeoutException
from rclpy.node import Node

from simplebot_navigation.ros.simulator_node import SimulatorNode

MAX_CALLBACKS_PER_ROUND = 20000
QUIET_PASSES = 2


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
        self._pending: set = set()
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
        """One physics step, then every callback it caused."""
        self.simulator.advance(self.dt)
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

    # -- idle detection ---------------------------------------------------------------------------
    def settle(self) -> int:
        """Run callbacks until the graph is idle; returns how many ran."""
        ran = 0
        busy: Counter = Counter()
        quiet = 0
        while quiet < QUIET_PASSES:
            progressed = resumed = False
            for handler, entity, node in self._one_pass():
                known = handler in self._pending
                handler()
                if handler.exception() is not None:
                    raise handler.exception()
                ran += 1
                if handler.done():
                    self._pending.discard(handler)
                elif known:
                    resumed = True
                    continue
                else:
                    self._pending.add(handler)
                progressed = True
                busy[_describe(entity, node)] += 1
                if ran > self.max_callbacks_per_round:
                    top = ", ".join(f"{name} x{count}" for name, count in busy.most_common(3))
                    raise LockstepError(f"the nodes are still busy after {ran} callbacks at sim time "
                                        f"{self.time:.3f} s (a publish/subscribe loop?); busiest: {top}")
            if progressed:
                quiet = 0
            elif not resumed:
                break
            else:
                quiet += 1
        self._pending = {task for task in self._pending if not task.done()}
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


def _describe(entity, node) -> str:
    where = node.get_fully_qualified_name() if node is not None else "executor"
    what = getattr(entity, "topic_name", None) or getattr(entity, "srv_name", None) or type(entity).__name__
    return f"{where}:{what}"
