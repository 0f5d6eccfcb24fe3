"""Lockstep: the simulator advances only while every other node of the process is idle (docs/design.md §3).

One single-threaded executor holds the simulator (``real_time_factor: 0``) and the nodes it drives.
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

Each pass is rclpy's own (``Executor._wait_for_ready_callbacks``: the pending tasks, one zero-timeout wait
on every entity that can execute, then the ready callbacks node by node in the same order), except that the
wait set is built once and kept until a node adds or removes an entity, and plain subscription and timer
callbacks run directly instead of in a coroutine Task, as ``ros/executor.py``'s lean executor does both.
The wait-set builds were about half of a lockstep run's time. Where the installed rclpy differs from what
that relies on (``rclpy_differences``), rclpy's own pass runs.
"""

from __future__ import annotations

import functools
import inspect
import math
import time
from collections import Counter
from typing import Callable, Iterable, Iterator

from rclpy.clock import ClockType
from rclpy.executors import ExternalShutdownException, ShutdownException, SingleThreadedExecutor, TimeoutException
from rclpy.node import Node
from rclpy.task import Task

from simplebot_navigation.ros.executor import LeanExecutor, WaitSetEntities, rclpy_differences
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode

MAX_CALLBACKS_PER_ROUND = 20000
_NEW = object()


class LockstepError(TimeoutError):
    """Time could not advance as asked: the graph never became idle, or a wall-clock guard expired.

    The message says at which sim time and, for a busy graph, which callbacks kept it busy."""


class _OrderedExecutor(LeanExecutor):
    """An executor that visits its nodes in the order they were added, for the driver's passes (it never spins).
    The lean executor's wait set, kept until an entity is added or removed, and its direct callbacks serve
    ``ready_callbacks``; where rclpy differs from what they rely on, the driver uses rclpy's own pass."""

    def __new__(cls, *, context=None):
        return SingleThreadedExecutor.__new__(cls)

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

    def _wait_once(self) -> tuple[dict, set]:
        """The kept wait set filled with every entity that can execute, one zero-timeout wait: the ready
        entities' pointers by kind, and the waitables it waited on."""
        if self._entities is None:
            self._entities = WaitSetEntities(self)
        ws = self._entities.wait_set
        ws.clear_entities()
        can_execute = self.can_execute
        kept = self._entities
        for entities, add in ((kept.subscriptions, ws.add_subscription), (kept.clients, ws.add_client),
                              (kept.services, ws.add_service), (kept.timers, ws.add_timer)):
            for handle, entity, _ in entities:
                if can_execute(entity):
                    add(handle)
        guards = []
        for handle, guard, _ in self._entities.guards:
            if guard is None or can_execute(guard):
                if guard is not None:
                    if guard._executor_triggered:     # triggered but not handled: trigger again, as rclpy does
                        guard.trigger()
                    guards.append(guard)
                ws.add_guard_condition(handle)
        waitables = {waitable for waitable, _ in self._entities.waitables if can_execute(waitable)}
        for waitable, _ in self._entities.waitables:
            if waitable in waitables:
                waitable.add_to_wait_set(ws)
        ws.wait(0)
        if self._is_shutdown:
            raise ShutdownException()
        if not self._context.ok():
            raise ExternalShutdownException()
        ready = {kind: set(ws.get_ready_entities(kind))
                 for kind in ("subscription", "guard_condition", "timer", "client", "service")}
        for guard in guards:
            if guard.handle.pointer in ready["guard_condition"]:
                guard._executor_triggered = True
        return ready, waitables

    def ready_callbacks(self) -> Iterator[tuple]:
        """One pass as rclpy's ``_wait_for_ready_callbacks(timeout_sec=0)`` makes it, on a kept wait set: the
        pending tasks, then whatever one zero-timeout wait found ready, as (handler, entity, node); a handler is
        a Task, or for a plain subscription or timer callback a function that runs it."""
        nodes = self.get_nodes()
        with self._tasks_lock:
            tasks = list(self._tasks)
        for task, entity, node in reversed(tasks):
            if not task.executing() and not task.done() and (node is None or node in nodes):
                yield task, entity, node
        with self._tasks_lock:
            self._tasks = [t for t in self._tasks if not t[0].done() and not t[0].cancelled()]
        ready, waitables = self._wait_once()
        ws = self._entities.wait_set            # kept: a callback below may add an entity and drop the cache
        subscriptions_ready, timers_ready = ready["subscription"], ready["timer"]
        clients_ready, services_ready = ready["client"], ready["service"]
        for node in nodes:
            for waitable in node.waitables:
                if waitable in waitables and waitable.is_ready(ws) and waitable.callback_group.can_execute(waitable):
                    yield self._make_handler(waitable, node, self._take_waitable), waitable, node
        for node in nodes:
            for timer in node.timers:
                if (timer.handle.pointer in timers_ready and timer.handle.is_timer_ready()
                        and timer.callback_group.can_execute(timer)):
                    if inspect.iscoroutinefunction(timer.callback):
                        yield self._make_handler(timer, node, self._take_timer), timer, node
                    else:
                        yield functools.partial(self._run_timer, timer, node), timer, node
            for sub in node.subscriptions:
                if sub.handle.pointer in subscriptions_ready and sub.callback_group.can_execute(sub):
                    if inspect.iscoroutinefunction(sub.callback):
                        yield self._make_handler(sub, node, self._take_subscription), sub, node
                    else:
                        yield functools.partial(self._run_subscription, sub, node), sub, node
            for guard in node.guards:
                if guard._executor_triggered and guard.callback_group.can_execute(guard):
                    yield self._make_handler(guard, node, self._take_guard_condition), guard, node
            for client in node.clients:
                if client.handle.pointer in clients_ready and client.callback_group.can_execute(client):
                    yield self._make_handler(client, node, self._take_client), client, node
            for service in node.services:
                if service.handle.pointer in services_ready and service.callback_group.can_execute(service):
                    yield self._make_handler(service, node, self._take_service), service, node


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
                handler()           # a plain callback run directly raises here
                ran += 1
                if isinstance(handler, Task):
                    if handler.exception() is not None:
                        raise handler.exception()
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
        if not rclpy_differences():
            yield from self.executor.ready_callbacks()
            return
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
