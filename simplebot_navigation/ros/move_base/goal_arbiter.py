"""The goal arbiter of move_base: the one owner of the active goal, whichever front door it came by.

The front doors (the simple goal topic, the MoveBase action, Nav2's actions and behaviours) check a request's pose
once (move_base_goal.GoalCheck) and hand the goal here; everything that ends a goal (the control cycle, a cancel,
the supervisor, a preemption) ends it here. So one goal is active at a time, a new one preempts the one before,
and every end is counted, reported and, for an action, answered the same way.
"""

from __future__ import annotations

import time
from typing import Callable

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from geometry_msgs.msg import PoseStamped

from simplebot_navigation.ros.conversions import pose_to_xyyaw
from simplebot_navigation.ros.move_base.move_base_goal import MoveBaseGoal

#: the goal outcomes move_base counts, by actionlib status
OUTCOMES = {ActionlibStatus.SUCCEEDED: "succeeded", ActionlibStatus.ABORTED: "aborted",
            ActionlibStatus.PREEMPTED: "preempted"}


class GoalArbiter:
    """Owns the active MoveBaseGoal. ``core`` is the state machine (MoveBaseCore) that drives it, ``stop()`` sends
    the base a zero velocity, ``now()`` is node time in seconds, ``show_target(pose)`` publishes an accepted goal
    (``~/current_goal``). Listeners: ``on_accept(goal)`` when a goal becomes active, ``on_end(goal)`` when one
    ends (set with ``listen``; the supervisor and the status reports)."""

    def __init__(self, core, stop: Callable[[], None], now: Callable[[], float], logger,
                 show_target: Callable[[PoseStamped], None]):
        self._core, self.stop, self._now, self._log, self._show_target = core, stop, now, logger, show_target
        self.active: MoveBaseGoal | None = None
        self.finished: list[MoveBaseGoal] = []
        self._on_accept: list[Callable[[MoveBaseGoal], None]] = []
        self._on_end: list[Callable[[MoveBaseGoal], None]] = []

    def listen(self, on_accept=None, on_end=None) -> None:
        if on_accept is not None:
            self._on_accept.append(on_accept)
        if on_end is not None:
            self._on_end.append(on_end)

    # -- starting ---------------------------------------------------------------------------------
    def submit(self, goal: MoveBaseGoal, target: PoseStamped) -> None:
        """``goal`` becomes the active goal, driven to ``target``: its pose as GoalCheck returned it (valid, in
        the global frame, on the global costmap). The goal before it is preempted."""
        self._take_over(goal)
        self._show_target(target)
        xyyaw = pose_to_xyyaw(target.pose)
        self._log.info(f"new goal ({xyyaw[0]:.2f}, {xyyaw[1]:.2f}, yaw {xyyaw[2]:.2f}) in {target.header.frame_id}")
        self.stop()
        self._core.set_goal(xyyaw, self._now())

    def submit_behavior(self, goal: MoveBaseGoal) -> None:
        """A Nav2 behaviour (``goal.behavior``) becomes the active goal; the control cycle starts it from the
        robot's pose it reads next."""
        self._take_over(goal)
        self._core.reset()
        self.stop()

    def reject(self, goal: MoveBaseGoal, reason: str, cause: str) -> None:
        """A move_base goal whose pose failed GoalCheck: as ROS 1's move_base, it still preempts the active goal
        (the robot stops), then ends aborted with the reason."""
        self._take_over(goal)
        self._log.error(f"Aborting on goal because it was sent with an invalid goal: {reason}")
        self.finish(goal, ActionlibStatus.ABORTED, reason, cause)

    def _take_over(self, goal: MoveBaseGoal) -> None:
        if self.active is not None:
            self._end(self.active, ActionlibStatus.PREEMPTED, "preempted by a new goal")
        goal.status = ActionlibStatus.ACTIVE
        self.active = goal
        self._core.events.goal(self._now(), goal.id)
        for listener in self._on_accept:
            listener(goal)

    # -- ending -----------------------------------------------------------------------------------
    def cancel(self, goal_id: str = "") -> None:
        """Cancel the active goal (any goal for an empty id, as actionlib's GoalID), stopping the robot."""
        if self.active is not None and (not goal_id or goal_id == self.active.id):
            self._log.info("goal canceled")
            self.finish(self.active, ActionlibStatus.PREEMPTED, "canceled")

    def finish(self, goal: MoveBaseGoal, status: int, text: str, cause: str = "") -> None:
        """End ``goal`` with an actionlib status, the reason, and for an abort its cause (Nav2's error codes). When
        it is the active goal the state machine drops it and the robot stops."""
        if goal is self.active:
            self._core.reset()
            self.stop()
        self._end(goal, status, text, cause)

    def _end(self, goal: MoveBaseGoal, status: int, text: str, cause: str = "") -> None:
        goal.status, goal.text, goal.cause = status, text, cause
        goal.finished_wall = time.monotonic()
        self._core.events.outcome(self._now(), OUTCOMES.get(status, f"status {status}"), text)
        if goal is self.active:
            self.active = None
        self.finished.append(goal)
        if goal.done is not None and not goal.done.done():
            goal.done.set_result(status)
        for listener in self._on_end:
            listener(goal)

    def forget_finished(self, older_than_wall_s: float) -> None:
        """Drop finished goals that ended more than this many wall seconds ago (the status list keeps the rest)."""
        now = time.monotonic()
        self.finished = [g for g in self.finished if now - g.finished_wall < older_than_wall_s]
