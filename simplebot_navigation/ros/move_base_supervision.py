"""What move_base does when its inputs fail: a stopped clock, missing data, a backward time jump, and
when its own planners fail with an exception.

A mixin of MoveBaseNode: it works on the node's goal, state machine, costmaps and controller, and is
kept apart so the node's file stays about its interfaces.
"""

from __future__ import annotations

import time
import traceback
from pathlib import Path

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from rclpy.clock import JumpHandle, JumpThreshold, TimeJump
from rclpy.duration import Duration

from simplebot_navigation.ros.move_base_goal import MoveBaseGoal


class MoveBaseSupervision:
    """The watchdog (steady clock), max_wait, the reaction to time jumping back, and internal errors."""

    def _abort_on_internal_error(self, goal: MoveBaseGoal, exc: Exception) -> None:
        """Stop the robot and end the goal with the error; the node stays up for the next goal."""
        where = traceback.extract_tb(exc.__traceback__)[-1]
        text = (f"internal error in the control cycle: {type(exc).__name__}: {exc} "
                f"({Path(where.filename).name}:{where.lineno}); robot stopped, goal aborted")
        self.get_logger().error(text + "\n" + "".join(traceback.format_exception(exc)))
        self.core.reset()
        self._publish_zero()
        self._finish(goal, ActionlibStatus.ABORTED, text)

    def _watch_for_time_jumps(self) -> JumpHandle:
        return self.get_clock().create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False),
            post_callback=self._on_time_jump)

    def _watchdog(self) -> None:
        """Stop the robot when the control loop has not run for watchdog_timeout of wall time while a goal is
        active: the loop runs on /clock, so a dead simulator (or time source) would leave the last command standing."""
        silent = time.monotonic() - self._last_cycle_wall
        if self.goal is None or silent < self.cfg.watchdog_timeout:
            return
        self._publish_zero()
        if not self._watchdog_tripped:
            self._watchdog_tripped = True
            self.get_logger().error(f"no control cycle for {silent:.2f} s of wall time (is /clock running? "
                                    f"node time {self._now():.2f} s): robot stopped")
        if 0 < self.cfg.max_wait < silent:
            self._abort_waiting(f"no control cycle for {silent:.0f} s of wall time (is /clock running?)")

    def _on_time_jump(self, jump: TimeJump) -> None:
        """A restarted simulator or a looped bag: what was seen belongs to another timeline. Costmaps and the
        controller start again (TF clears itself), and a goal in progress is aborted, since its robot pose,
        plan and timers are gone. New goals work as soon as data flows again."""
        back = -jump.delta.nanoseconds * 1e-9
        for costmap in (self.global_costmap, self.local_costmap):
            costmap.forget_history()
        self.controller.reset()
        self._waiting_since = None
        self.get_logger().warn(f"time jumped back by {back:.2f} s (simulator restarted?): costmaps cleared")
        if self.goal is not None:
            reason = f"time jumped back by {back:.2f} s (simulator restarted?)"
            self.get_logger().error(f"Aborting the goal: {reason}")
            self.core.reset()
            self._publish_zero()
            self._finish(self.goal, ActionlibStatus.ABORTED, reason)

    def _wait_for_data(self, reason: str) -> None:
        """A goal may wait max_wait seconds of node time for its pose and sensors, then it is aborted."""
        now = self._now()
        if self._waiting_since is None:
            self._waiting_since = now
        elif 0 < self.cfg.max_wait < now - self._waiting_since:
            self._abort_waiting(f"{reason} for {now - self._waiting_since:.0f} s")

    def _abort_waiting(self, reason: str) -> None:
        message = f"Aborting the goal: {reason} (max_wait {self.cfg.max_wait:g} s)"
        self.get_logger().error(message)
        self.core.reset()
        self._publish_zero()
        self._finish(self.goal, ActionlibStatus.ABORTED, message)

