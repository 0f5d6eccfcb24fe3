"""What move_base does when its inputs fail: a stopped clock, missing data, a backward time jump, and
when its own planners fail with an exception.

It ends goals through the GoalArbiter and resets the node's parts through the one callable it is given; it
never sees the node.
"""

from __future__ import annotations

import threading
import time
import traceback
from pathlib import Path
from typing import Callable

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from rclpy.clock import JumpHandle, JumpThreshold, TimeJump
from rclpy.duration import Duration

from simplebot_navigation.ros.move_base.move_base_goal import MoveBaseGoal


class CommandWatchdog:
    """Zero velocity from a thread of its own when the control loop has been silent for ``timeout()`` seconds of
    wall time while ``active()``.

    The executor's thread cannot keep this promise: a dead /clock stops its timers, and a long callback (a
    costmap rebuilt after a parameter change, a burst of messages on a loaded machine) delays everything queued
    behind it, so the last command would stand. This thread only needs the GIL, which the compiled kernels
    release and the interpreter hands over every few milliseconds.
    """

    def __init__(self, publish_zero: Callable[[], None], timeout: Callable[[], float], active: Callable[[], bool],
                 period_s: float = 0.05):
        self._publish_zero, self._timeout, self._active, self._period = publish_zero, timeout, active, period_s
        self.last_beat = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="move_base watchdog", daemon=True)
        self._thread.start()

    def beat(self) -> None:
        """The control loop ran."""
        self.last_beat = time.monotonic()

    def silent_for(self) -> float:
        return time.monotonic() - self.last_beat

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)

    def _run(self) -> None:
        while not self._stop.wait(self._period):
            timeout = self._timeout()
            if timeout > 0 and self._active() and self.silent_for() >= timeout:
                try:
                    self._publish_zero()
                except Exception:  # noqa: BLE001 - the node is shutting down under this thread
                    return


class MoveBaseSupervisor:
    """The watchdog, max_wait, the reaction to time jumping back, and internal errors of a move_base node.

    It gets what it watches: the node's ``clock`` and ``logger``, its configuration ``cfg`` (watchdog_timeout,
    max_wait, read live), the GoalArbiter, and ``forget()``, which drops what a restarted timeline makes wrong
    (costmap history, tracks, the controller's trajectory). The control cycle tells it ``loop_ran()`` and, while the
    goal lacks its pose or sensors, ``wait_for_data`` (``data_ok()`` when they are back); the steady housekeeping
    timer calls ``check_watchdog()``."""

    def __init__(self, clock, logger, cfg, arbiter, forget: Callable[[], None]):
        self._clock, self._log, self.cfg, self.arbiter, self._forget = clock, logger, cfg, arbiter, forget
        self.watchdog = CommandWatchdog(arbiter.stop, lambda: cfg.watchdog_timeout,
                                        lambda: arbiter.active is not None)
        self._tripped = False
        self._waiting_since: float | None = None   # node time since when the goal lacks its pose or sensors
        self._jump_handle: JumpHandle = clock.create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False),
            post_callback=self._on_time_jump)
        arbiter.listen(on_accept=self.goal_accepted)

    def _now(self) -> float:
        return self._clock.now().nanoseconds / 1e9

    def goal_accepted(self, _goal=None) -> None:
        """A new goal: the watchdog judges the loop from now on, and the goal has not waited yet."""
        self.watchdog.beat()
        self._waiting_since = None

    def loop_ran(self) -> None:
        self.watchdog.beat()
        if self._tripped:
            self._tripped = False
            self._log.info("control loop running again")

    def stop(self) -> None:
        self.watchdog.stop()

    def abort_on_internal_error(self, goal: MoveBaseGoal, exc: Exception) -> None:
        """Stop the robot and end the goal with the error; the node stays up for the next goal."""
        where = traceback.extract_tb(exc.__traceback__)[-1]
        text = (f"internal error in the control cycle: {type(exc).__name__}: {exc} "
                f"({Path(where.filename).name}:{where.lineno}); robot stopped, goal aborted")
        self._log.error(text + "\n" + "".join(traceback.format_exception(exc)))
        self.arbiter.finish(goal, ActionlibStatus.ABORTED, text)

    def check_watchdog(self) -> None:
        """Say why the robot was stopped, and abort after max_wait. The loop runs on /clock, so a dead simulator
        (or time source) silences it; the watchdog's thread has already sent the zero command."""
        cfg = self.cfg
        silent = self.watchdog.silent_for()
        if cfg.watchdog_timeout <= 0 or self.arbiter.active is None or silent < cfg.watchdog_timeout:
            return
        if not self._tripped:
            self._tripped = True
            self._log.error(f"no control cycle for {silent:.2f} s of wall time (is /clock running? "
                                         f"node time {self._now():.2f} s): robot stopped")
        if 0 < cfg.max_wait < silent:
            self._abort_waiting(f"no control cycle for {silent:.0f} s of wall time (is /clock running?)")

    def _on_time_jump(self, jump: TimeJump) -> None:
        """A restarted simulator or a looped bag: what was seen belongs to another timeline. Costmaps and the
        controller start again (TF clears itself), and a goal in progress is aborted, since its robot pose,
        plan and timers are gone. New goals work as soon as data flows again."""
        back = -jump.delta.nanoseconds * 1e-9
        self._forget()
        self._waiting_since = None
        self._log.warn(f"time jumped back by {back:.2f} s (simulator restarted?): costmaps cleared")
        if self.arbiter.active is not None:
            reason = f"time jumped back by {back:.2f} s (simulator restarted?)"
            self._log.error(f"Aborting the goal: {reason}")
            self.arbiter.finish(self.arbiter.active, ActionlibStatus.ABORTED, reason)

    def data_ok(self) -> None:
        self._waiting_since = None

    def wait_for_data(self, reason: str) -> None:
        """A goal may wait max_wait seconds of node time for its pose and sensors, then it is aborted."""
        now = self._now()
        if self._waiting_since is None:
            self._waiting_since = now
        elif 0 < self.cfg.max_wait < now - self._waiting_since:
            self._abort_waiting(f"{reason} for {now - self._waiting_since:.0f} s")

    def _abort_waiting(self, reason: str) -> None:
        message = f"Aborting the goal: {reason} (max_wait {self.cfg.max_wait:g} s)"
        self._log.error(message)
        self.arbiter.finish(self.arbiter.active, ActionlibStatus.ABORTED, message)
