"""A single-threaded executor that costs less per wake-up than rclpy's.

move_base wakes some 250 times a second at real time (/clock at 100 Hz, TF and odometry at 50 Hz,
scans, timers). rclpy's SingleThreadedExecutor rebuilds its wait set in Python on every wake: it
gathers every entity of every node, enters a context per handle, creates a new wait set, and wraps
each callback in a coroutine Task whose bookkeeping triggers the executor's guard condition twice,
which makes the next wait return at once for an empty round. That was about half of move_base's CPU.

This executor keeps the entity lists and the wait set until a node adds or removes an entity (rclpy
then calls ``wake()``), runs subscription and timer callbacks directly, and hands only waitables
(action servers, QoS events), services, clients, guard conditions and coroutine callbacks to rclpy's
Task machinery, so their semantics stay rclpy's. It is only for one thread, and callback groups keep
their meaning: an entity whose group is busy (a suspended coroutine) waits, as in rclpy.

All this leans on rclpy's private internals, which pyproject.toml pins. Where the installed rclpy differs
in any of them (``rclpy_differences``), ``LeanExecutor()`` warns once and is rclpy's SingleThreadedExecutor.
"""

from __future__ import annotations

import functools
import inspect

import rclpy.executors
from rclpy.client import Client
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.exceptions import InvalidHandle
from rclpy.logging import get_logger
from rclpy.node import Node
from rclpy.service import Service
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from rclpy.utilities import timeout_sec_to_nsec
from rclpy.waitable import Waitable

_CLASSES = {c.__name__: c for c in (Executor, SingleThreadedExecutor, Node, Subscription, Timer, Service, Client,
                                    GuardCondition, Waitable)}
#: Executor methods the lean one calls, with the positional arguments it passes (self included)
_CALLED = {"_make_handler": 4, "_take_timer": 2, "_take_subscription": 2, "_take_service": 2, "_take_client": 2,
           "_take_guard_condition": 2, "_take_waitable": 2}
#: rclpy functions and the attributes or methods they must set or call for the lean executor to work: the
#: executor's state, the route from spin_once to the override, the entities' flags, and the wake-up
#: that invalidates the cached wait set whenever a node adds or removes an entity
_USES = {"Executor.__init__": ("_context", "_tasks", "_tasks_lock", "_guard", "_sigint_gc", "_is_shutdown"),
         "SingleThreadedExecutor.spin_once": ("_spin_once_impl",),
         "SingleThreadedExecutor.spin_once_until_future_complete": ("_spin_once_impl",),
         "Subscription.__init__": ("_executor_event",), "Subscription.callback": ("_callback_type", "MessageOnly"),
         "GuardCondition.__init__": ("_executor_event", "_executor_triggered"),
         **{f"{kind}.__init__": ("_executor_event",) for kind in ("Timer", "Service", "Client", "Waitable")},
         "Node._wake_executor": ("wake",),
         **{f"Node.{verb}_{kind}": ("_wake_executor",) for verb in ("create", "destroy")
            for kind in ("subscription", "timer", "service", "client", "guard_condition")},
         "Node.add_waitable": ("_wake_executor",), "Node.remove_waitable": ("_wake_executor",)}
#: methods of rclpy's C extension the lean executor calls on wait sets and handles
_NATIVE = {"WaitSet": ("clear_entities", "add_subscription", "add_timer", "add_service", "add_client",
                       "add_guard_condition", "wait", "get_ready_entities"),
           "Subscription": ("take_message", "pointer"), "Timer": ("call_timer", "is_timer_ready", "pointer")}


@functools.cache
def rclpy_differences() -> tuple[str, ...]:
    """How the installed rclpy differs from the internals the lean executor relies on; warns once if it does.

    Checked without building an executor: methods by the arguments they are called with, instance attributes
    by the names rclpy's own functions use (``co_names``), the C extension's methods by presence. Cached, so
    a process warns once however many executors it builds.
    """
    found = []
    for name, count in _CALLED.items():
        try:
            inspect.signature(getattr(Executor, name)).bind(*range(count))
        except AttributeError:
            found.append(f"no Executor.{name}")
        except TypeError:
            found.append(f"Executor.{name} does not take {count - 1} positional argument{'s' * (count > 2)}")
    impl = getattr(SingleThreadedExecutor, "_spin_once_impl", None)
    if impl is None or list(inspect.signature(impl).parameters) != ["self", "timeout_sec", "wait_condition"]:
        found.append("SingleThreadedExecutor._spin_once_impl is not (self, timeout_sec, wait_condition)")
    for where, names in _USES.items():
        kind, function = where.split(".")
        function = getattr(_CLASSES[kind], function, None)
        code = getattr(getattr(function, "fset", function), "__code__", None)     # a property: its setter
        missing = sorted(set(names) - set(code.co_names if code else ()))
        found += [f"{where} does not use {', '.join(missing)}"] if missing else []
    if not hasattr(rclpy.executors, "TimeoutObject"):
        found.append("no rclpy.executors.TimeoutObject")
    for kind, methods in _NATIVE.items():
        missing = [m for m in methods if not hasattr(getattr(_rclpy, kind, None), m)]
        found += [f"no _rclpy.{kind}.{', '.join(missing)}"] if missing else []
    if found:
        get_logger("lean_executor").warning(
            f"rclpy differs from what LeanExecutor relies on ({'; '.join(found)}): rclpy's SingleThreadedExecutor "
            "spins instead")
    return tuple(found)


class WaitSetEntities:
    """What an executor waits on, gathered once per change of the nodes' entities, with one wait set sized for
    all of them (also the lockstep driver's, ros/simulator/lockstep.py)."""

    def __init__(self, executor: Executor):
        nodes = executor.get_nodes()
        self.subscriptions = [(s.handle, s, n) for n in nodes for s in n.subscriptions]
        self.timers = [(t.handle, t, n) for n in nodes for t in n.timers]
        self.services = [(s.handle, s, n) for n in nodes for s in n.services]
        self.clients = [(c.handle, c, n) for n in nodes for c in n.clients]
        self.guards = [(g.handle, g, n) for n in nodes for g in n.guards]
        self.guards += [(executor._guard.handle, None, None), (executor._sigint_gc.handle, None, None)]
        self.waitables = [(w, n) for n in nodes for w in n.waitables]
        extra = [w.get_num_entities() for w, _ in self.waitables]
        self.wait_set = _rclpy.WaitSet(
            len(self.subscriptions) + sum(e.num_subscriptions for e in extra),
            len(self.guards) + sum(e.num_guard_conditions for e in extra),
            len(self.timers) + sum(e.num_timers for e in extra),
            len(self.clients) + sum(e.num_clients for e in extra),
            len(self.services) + sum(e.num_services for e in extra),
            sum(e.num_events for e in extra), executor._context.handle)
        by_pointer = lambda items: {h.pointer: (e, n) for h, e, n in items}  # noqa: E731
        self.ready_subscription = by_pointer(self.subscriptions)
        self.ready_timer = by_pointer(self.timers)
        self.ready_service = by_pointer(self.services)
        self.ready_client = by_pointer(self.clients)
        self.ready_guard = {h.pointer: (g, n) for h, g, n in self.guards if g is not None}

    def fill(self) -> None:
        ws = self.wait_set
        ws.clear_entities()
        for handle, _, _ in self.subscriptions:
            ws.add_subscription(handle)
        for handle, _, _ in self.timers:
            ws.add_timer(handle)
        for handle, _, _ in self.services:
            ws.add_service(handle)
        for handle, _, _ in self.clients:
            ws.add_client(handle)
        for handle, _, _ in self.guards:
            ws.add_guard_condition(handle)
        for waitable, _ in self.waitables:
            waitable.add_to_wait_set(ws)


class LeanExecutor(SingleThreadedExecutor):
    """rclpy's SingleThreadedExecutor API (spin, spin_once, spin_until_future_complete), cheaper per wake."""

    def __new__(cls, *, context=None):
        if rclpy_differences():
            return SingleThreadedExecutor(context=context)
        return super().__new__(cls)

    def __init__(self, *, context=None):
        super().__init__(context=context)
        self._entities: WaitSetEntities | None = None

    def wake(self) -> None:
        self._entities = None
        super().wake()

    def add_node(self, node) -> bool:
        self._entities = None
        return super().add_node(node)

    def remove_node(self, node) -> None:
        self._entities = None
        super().remove_node(node)

    def _spin_once_impl(self, timeout_sec=None, wait_condition=lambda: False) -> None:
        if self._is_shutdown or wait_condition():
            return
        self._run_tasks()
        if self._entities is None:
            self._entities = WaitSetEntities(self)
        entities = self._entities
        entities.fill()
        if isinstance(timeout_sec, rclpy.executors.TimeoutObject):
            timeout_sec = timeout_sec.timeout
        entities.wait_set.wait(timeout_sec_to_nsec(timeout_sec))
        if self._is_shutdown:
            return
        if not self._context.ok():
            raise ExternalShutdownException()
        ws = entities.wait_set
        ready_waitables = [(w, n) for w, n in entities.waitables if w.is_ready(ws)]
        for pointer in ws.get_ready_entities("timer"):
            timer, node = entities.ready_timer.get(pointer, (None, None))
            if timer is not None and timer.handle.is_timer_ready():
                self._run_timer(timer, node)
        for pointer in ws.get_ready_entities("subscription"):
            sub, node = entities.ready_subscription.get(pointer, (None, None))
            if sub is not None:
                self._run_subscription(sub, node)
        for waitable, node in ready_waitables:
            self._run_as_task(waitable, node, self._take_waitable)
        for pointer in ws.get_ready_entities("service"):
            entity = entities.ready_service.get(pointer)
            if entity is not None:
                self._run_as_task(entity[0], entity[1], self._take_service)
        for pointer in ws.get_ready_entities("client"):
            entity = entities.ready_client.get(pointer)
            if entity is not None:
                self._run_as_task(entity[0], entity[1], self._take_client)
        for pointer in ws.get_ready_entities("guard_condition"):
            entity = entities.ready_guard.get(pointer)
            if entity is not None:
                entity[0]._executor_triggered = True
                self._run_as_task(entity[0], entity[1], self._take_guard_condition)

    def _run_tasks(self) -> None:
        """Resume the coroutine tasks (action goals, futures' callbacks) once, as rclpy does before each wait."""
        with self._tasks_lock:
            tasks = list(self._tasks)
        for task, _, _ in tasks:
            if not task.executing() and not task.done():
                task()
                if task.exception() is not None:
                    raise task.exception()
        with self._tasks_lock:
            self._tasks = [t for t in self._tasks if not t[0].done() and not t[0].cancelled()]

    def _run_as_task(self, entity, node, take) -> None:
        if entity._executor_event or not entity.callback_group.can_execute(entity):
            return
        task = self._make_handler(entity, node, take)
        task()
        if task.exception() is not None:
            raise task.exception()

    def _run_timer(self, timer, node) -> None:
        if inspect.iscoroutinefunction(timer.callback) or not timer.callback_group.can_execute(timer):
            self._run_as_task(timer, node, self._take_timer)
            return
        group = timer.callback_group
        if not group.beginning_execution(timer):
            return
        try:
            timer.handle.call_timer()
        except InvalidHandle:           # destroyed by an earlier callback of this round
            group.ending_execution(timer)
            return
        try:
            timer.callback()
        finally:
            group.ending_execution(timer)

    def _run_subscription(self, sub, node) -> None:
        if inspect.iscoroutinefunction(sub.callback) or not sub.callback_group.can_execute(sub):
            self._run_as_task(sub, node, self._take_subscription)
            return
        group = sub.callback_group
        if not group.beginning_execution(sub):
            return
        try:
            try:
                taken = sub.handle.take_message(sub.msg_type, sub.raw)
            except InvalidHandle:       # destroyed by an earlier callback of this round
                taken = None
            if taken is not None:
                if sub._callback_type is Subscription.CallbackType.MessageOnly:
                    sub.callback(taken[0])
                else:
                    sub.callback(*taken)
        finally:
            group.ending_execution(sub)

