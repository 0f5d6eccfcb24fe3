"""move_base's executeCycle (REFERENCE §1.3) as a pure state machine.

The planner runs synchronously inside the cycle (a plan on the lab's costmap takes about a
millisecond), which keeps runs deterministic in lockstep; ROS 1's planner thread and its triple
buffer collapse into one call. Everything else follows move_base: patience timers, planning
retries, oscillation detection, the recovery sequence and its reset rules, and the abort messages.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Callable, Protocol

import numpy as np

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.recovery import Recovery


class State(Enum):
    IDLE = "IDLE"
    PLANNING = "PLANNING"
    CONTROLLING = "CONTROLLING"
    CLEARING = "CLEARING"


class Trigger(Enum):
    PLANNING_R = "PLANNING_R"
    CONTROLLING_R = "CONTROLLING_R"
    OSCILLATION_R = "OSCILLATION_R"


ABORT_MESSAGES = {
    Trigger.PLANNING_R: "Failed to find a valid plan. Even after executing recovery behaviors.",
    Trigger.CONTROLLING_R: "Failed to find a valid control. Even after executing recovery behaviors.",
    Trigger.OSCILLATION_R: "Robot is oscillating. Even after executing recovery behaviors.",
}


@dataclass
class ControlResult:
    ok: bool
    v: float = 0.0
    omega: float = 0.0
    message: str = ""


class Controller(Protocol):
    def set_plan(self, plan: np.ndarray) -> bool: ...

    def compute(self) -> ControlResult: ...

    def is_goal_reached(self) -> bool: ...

    def reset(self) -> None: ...


@dataclass
class CycleOutput:
    cmd: tuple[float, float] | None   # velocity to publish (None: publish nothing)
    outcome: str | None = None        # "succeeded" or "aborted" when the goal ends this cycle
    message: str = ""                 # why it ended, or a warning for this cycle
    event: str = ""                   # something worth an info log (new plan, recovery started ...)


class MoveBaseCore:
    def __init__(self, config: MoveBaseConfig, recoveries: list[Recovery],
                 plan: Callable[[tuple[float, float, float]], np.ndarray | None], controller: Controller):
        self.cfg = config
        self.recoveries = recoveries
        self._plan = plan
        self.controller = controller
        self.goal: tuple[float, float, float] | None = None
        self.state = State.IDLE
        self.trigger = Trigger.PLANNING_R
        self.recovery_index = 0
        self.replans = 0
        self.recoveries_run = 0
        self.last_plan_message = ""
        self._active_recovery: Recovery | None = None
        self._retries = 0
        self._last_valid_plan = 0.0
        self._last_valid_control = 0.0
        self._next_plan_time = 0.0
        self._oscillation_time = 0.0
        self._oscillation_pose: tuple[float, float] | None = None

    # -- goals ------------------------------------------------------------------------------------
    def set_goal(self, goal: tuple[float, float, float], now: float) -> None:
        """A new goal, or one that preempts the current goal."""
        self.goal = goal
        self.state = State.PLANNING
        self.recovery_index = 0
        self._active_recovery = None
        self._retries = 0
        self._last_valid_plan = self._last_valid_control = self._oscillation_time = now
        self._next_plan_time = now
        self._oscillation_pose = None
        self.controller.reset()

    def reset(self) -> None:
        """resetState: drop the goal; the caller publishes a zero velocity."""
        self.goal = None
        self.state = State.IDLE
        self.recovery_index = 0
        self.trigger = Trigger.PLANNING_R
        self._active_recovery = None
        self.controller.reset()

    # -- one control cycle ------------------------------------------------------------------------
    def cycle(self, now: float, pose: tuple[float, float, float], local_costmap_current: bool,
              stale_message: str = "") -> CycleOutput:
        if self.goal is None:
            return CycleOutput(None)
        if self._oscillation_pose is None or math.hypot(pose[0] - self._oscillation_pose[0],
                                                        pose[1] - self._oscillation_pose[1]) \
                >= self.cfg.oscillation_distance:
            self._oscillation_time = now
            self._oscillation_pose = (pose[0], pose[1])
            if self.trigger == Trigger.OSCILLATION_R:
                self.recovery_index = 0
        if not local_costmap_current:
            return CycleOutput((0.0, 0.0), message="Sensor data is out of date, we're not going to allow "
                                                   f"commanding of the base for safety ({stale_message})")
        event = self._run_planner(now)
        if self.goal is None:  # the controller refused the plan
            return CycleOutput((0.0, 0.0), outcome="aborted", message=event)
        if self.state == State.PLANNING:
            return CycleOutput((0.0, 0.0), event=event)
        if self.state == State.CONTROLLING:
            out = self._control(now)
        else:
            out = self._clear(now, pose)
        if event and not out.event:
            out.event = event
        return out

    def _run_planner(self, now: float) -> str:
        """Plan when PLANNING, or periodically while CONTROLLING; returns what happened."""
        periodic = self.cfg.planner_frequency > 0 and self.state == State.CONTROLLING and now >= self._next_plan_time
        if self.state != State.PLANNING and not periodic:
            return ""
        if self.cfg.planner_frequency > 0:
            self._next_plan_time = now + 1.0 / self.cfg.planner_frequency
        plan = self._plan(self.goal)
        if plan is not None and len(plan):
            self._last_valid_plan = now
            self._retries = 0
            if not self.controller.set_plan(plan):
                self.reset()
                return "Failed to pass global plan to the controller, aborting."
            if self.trigger == Trigger.PLANNING_R:
                self.recovery_index = 0
            self.replans += 1
            if self.state == State.PLANNING:
                self.state = State.CONTROLLING
            return f"new plan with {len(plan)} poses"
        if self.state == State.PLANNING:
            self._retries += 1
            retries_exhausted = 0 <= self.cfg.max_planning_retries < self._retries
            if now > self._last_valid_plan + self.cfg.planner_patience or retries_exhausted:
                self.state = State.CLEARING
                self.trigger = Trigger.PLANNING_R
        return ""

    def _control(self, now: float) -> CycleOutput:
        if self.controller.is_goal_reached():
            self.reset()
            return CycleOutput((0.0, 0.0), outcome="succeeded", message="Goal reached")
        if self.cfg.oscillation_timeout > 0 and now > self._oscillation_time + self.cfg.oscillation_timeout:
            self.state = State.CLEARING
            self.trigger = Trigger.OSCILLATION_R
        result = self.controller.compute()
        if result.ok:
            self._last_valid_control = now
            if self.trigger == Trigger.CONTROLLING_R:
                self.recovery_index = 0
            return CycleOutput((result.v, result.omega))
        if now > self._last_valid_control + self.cfg.controller_patience:
            self.state = State.CLEARING
            self.trigger = Trigger.CONTROLLING_R
            return CycleOutput((0.0, 0.0), message=f"controller failed for {self.cfg.controller_patience:g} s: "
                                                   f"{result.message}")
        self.state = State.PLANNING
        self._last_valid_plan = now
        self._retries = 0
        return CycleOutput((0.0, 0.0), message=f"The local planner could not find a valid plan: {result.message}")

    def _clear(self, now: float, pose) -> CycleOutput:
        if self._active_recovery is None:
            if not (self.cfg.recovery_behavior_enabled and self.recovery_index < len(self.recoveries)):
                message = ABORT_MESSAGES[self.trigger]
                self.reset()
                return CycleOutput((0.0, 0.0), outcome="aborted", message=message)
            self._active_recovery = self.recoveries[self.recovery_index]
            self._active_recovery.start(now, pose)
            self.recoveries_run += 1
            started = f"executing recovery behavior {self._active_recovery.name} " \
                      f"({self.recovery_index + 1}/{len(self.recoveries)}) after {self.trigger.value}"
        else:
            started = ""
        step = self._active_recovery.tick(now, pose)
        if not step.done:
            return CycleOutput(step.cmd, event=started)
        self._active_recovery = None
        self._oscillation_time = now
        self._oscillation_pose = (pose[0], pose[1])
        self._last_valid_plan = now
        self._retries = 0
        self.state = State.PLANNING
        self.recovery_index += 1
        return CycleOutput(step.cmd if step.cmd is not None else (0.0, 0.0),
                           event="; ".join(m for m in (started, step.message) if m))
