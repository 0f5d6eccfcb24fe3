"""move_base's executeCycle (docs/reference.md §1.3) as a pure state machine.

The planner runs synchronously inside the cycle (a plan on the lab's costmap takes about a
millisecond), which keeps runs deterministic in lockstep; ROS 1's planner thread and its triple
buffer collapse into one call. Everything else follows move_base: patience timers, planning
retries, oscillation detection, the recovery sequence and the abort messages.

Four rules differ from ROS 1's, so that a robot that discovers its world as it drives ends every goal
instead of circling: a route it finds blocked is replaced, lack of progress is noticed however the robot
moves, a stuck local planner does not make the global planner repeat itself, and the recovery sequence
restarts only after real progress.
- A plan that runs into an obstacle seen after planning is replaced at once (as Nav2's IsPathValid does),
  even with planner_frequency 0. Only a crossing that is new and within BLOCKED_CHECK_AHEAD_M of the
  robot counts: poses the planner itself put on blocked cells (next to a robot standing in an inflated
  zone) do not, and cells far ahead that grazing rays erase and re-mark in turn would make the robot
  alternate between two routes. Such replans come at most once per BLOCKED_REPLAN_INTERVAL_S.
- ``progress_timeout`` (30 s; 0 disables): a robot that has for that long neither come
  oscillation_distance closer to the goal, nor got the plan length left below the least it has been
  during this goal by oscillation_distance, nor entered a square metre new to this goal runs the recovery
  behaviours (trigger PROGRESS_R). Nav2's progress checker counts any movement, and circling is movement.
- A local planner that fails sends move_base back to PLANNING only when its plan is at least
  MIN_REPLAN_INTERVAL_S old; until then it keeps the plan and stops the robot. ROS 1 replans after every
  failed cycle, hundreds of identical plans a minute while the local planner is what is stuck.
- After a recovery, a new plan or a valid control restarts the recovery sequence only once the robot has
  come oscillation_distance closer to the goal than it was before the sequence began. ROS 1 restarts it on
  any new plan, so a goal that cannot be reached would never abort.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Callable

import numpy as np

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.events import MoveBaseEvents
from simplebot_navigation.move_base.plugins import Controller
from simplebot_navigation.move_base.recovery import PoseTrail, Recovery


PROGRESS_CELL_M = 1.0  # size of the squares whose first visit counts as progress
BLOCKED_REPLAN_INTERVAL_S = 1.0
BLOCKED_CHECK_AHEAD_M = 3.0   # of plan ahead of the robot: what it drives within the next several seconds
MIN_REPLAN_INTERVAL_S = 1.0   # between plans made because the local planner failed


class State(Enum):
    IDLE = "IDLE"
    PLANNING = "PLANNING"
    CONTROLLING = "CONTROLLING"
    CLEARING = "CLEARING"


class Trigger(Enum):
    PLANNING_R = "PLANNING_R"
    CONTROLLING_R = "CONTROLLING_R"
    OSCILLATION_R = "OSCILLATION_R"
    PROGRESS_R = "PROGRESS_R"


ABORT_MESSAGES = {
    Trigger.PLANNING_R: "Failed to find a valid plan. Even after executing recovery behaviors.",
    Trigger.CONTROLLING_R: "Failed to find a valid control. Even after executing recovery behaviors.",
    Trigger.OSCILLATION_R: "Robot is oscillating. Even after executing recovery behaviors.",
    Trigger.PROGRESS_R: "No progress towards the goal. Even after executing recovery behaviors.",
}


@dataclass
class CycleOutput:
    cmd: tuple[float, float] | None   # velocity to publish (None: publish nothing)
    outcome: str | None = None        # "succeeded" or "aborted" when the goal ends this cycle
    message: str = ""                 # why it ended, or a warning for this cycle
    event: str = ""                   # something worth an info log (new plan, recovery started ...)
    cause: str = ""                   # why a goal was aborted: the recovery trigger, or "controller"


class MoveBaseCore:
    def __init__(self, config: MoveBaseConfig, recoveries: list[Recovery],
                 plan: Callable[[tuple[float, float, float], tuple[float, float, float]], np.ndarray | str],
                 controller: Controller,
                 plan_blocked: Callable[[np.ndarray, tuple[float, float, float]], np.ndarray] | None = None,
                 trail: PoseTrail | None = None):
        """``plan(start, goal)`` returns the poses (N, 3) from the cycle's robot pose or, on failure, the
        planner's reason; ``plan_blocked(poses, robot pose)`` marks the poses on cells the planner would not enter now;
        ``trail`` records where the robot drove (for recoveries that back up along it)."""
        self.cfg = config
        self.trail = trail if trail is not None else PoseTrail()
        self.recoveries = recoveries
        self._plan = plan
        self._plan_blocked = plan_blocked
        self._blocked_at_plan: np.ndarray | None = None   # poses of the plan already blocked when it was made
        self._last_blocked_replan = -math.inf
        self.controller = controller
        self.plan: np.ndarray | None = None
        self._plan_to_go = np.empty(0)     # plan length from each pose to the plan's end
        self._plan_made_at = -math.inf
        self._best_to_go = math.inf        # least plan length left to drive during this goal
        self.goal: tuple[float, float, float] | None = None
        self.state = State.IDLE
        self.trigger = Trigger.PLANNING_R
        self.recovery_index = 0
        self.events = MoveBaseEvents()
        self.last_plan_failure = ""
        self._active_recovery: Recovery | None = None
        self._retries = 0
        self._last_valid_plan = 0.0
        self._last_valid_control = 0.0
        self._next_plan_time = 0.0
        self._oscillation_time = 0.0
        self._oscillation_pose: tuple[float, float] | None = None
        self._closest = math.inf         # closest the robot has been to the goal
        self._progress_mark = math.inf   # ... when the running recovery sequence began
        self._progress_distance = math.inf   # distance to the goal at the last progress ...
        self._progress_time = 0.0            # ... and when that was
        self._visited: set[tuple[int, int]] = set()

    @property
    def replans(self) -> int:
        return self.events.replans

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
        self._last_blocked_replan = -math.inf
        self._oscillation_pose = None
        self._closest = self._progress_mark = self._progress_distance = math.inf
        self._progress_time = now
        self._visited.clear()
        self._plan_made_at = -math.inf
        self._best_to_go = math.inf
        self.plan = None
        self.last_plan_failure = ""
        self.controller.reset()

    def reset(self) -> None:
        """resetState: drop the goal; the caller publishes a zero velocity."""
        self.goal = None
        self.state = State.IDLE
        self.recovery_index = 0
        self.trigger = Trigger.PLANNING_R
        self._active_recovery = None
        self.plan = None
        self.controller.reset()

    # -- one control cycle ------------------------------------------------------------------------
    def cycle(self, now: float, pose: tuple[float, float, float], local_costmap_current: bool,
              stale_message: str = "") -> CycleOutput:
        if self.goal is None:
            return CycleOutput(None)
        distance = math.hypot(pose[0] - self.goal[0], pose[1] - self.goal[1])
        self._closest = min(self._closest, distance)
        self.trail.record(pose[0], pose[1])
        to_go = self._plan_left(pose)
        if to_go < math.inf and to_go <= self._best_to_go - self.cfg.oscillation_distance:
            self._best_to_go, self._progress_time = to_go, now
        cell = (math.floor(pose[0] / PROGRESS_CELL_M), math.floor(pose[1] / PROGRESS_CELL_M))
        if cell not in self._visited:
            self._visited.add(cell)
            self._progress_time = now
        if distance <= self._progress_distance - self.cfg.oscillation_distance:
            self._progress_distance, self._progress_time = distance, now
        if self.trigger == Trigger.PROGRESS_R and self._progress_since_recoveries():
            self.recovery_index = 0
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
        blocked = self._check_plan(now, pose)
        event = self._run_planner(now, pose)
        if blocked:
            event = f"{blocked}: replanning" + (f"; {event}" if event else "")
        if self.goal is None:  # the controller refused the plan
            return CycleOutput((0.0, 0.0), outcome="aborted", message=event, cause="controller")
        if self.state == State.PLANNING:
            return CycleOutput((0.0, 0.0), event=event)
        if self.state == State.CONTROLLING:
            out = self._control(now)
        else:
            out = self._clear(now, pose)
        if event and not out.event:
            out.event = event
        return out

    def _nearest_on_plan(self, pose) -> int:
        return int(np.argmin(np.hypot(self.plan[:, 0] - pose[0], self.plan[:, 1] - pose[1])))

    def _plan_left(self, pose) -> float:
        """Length of the current plan still to drive from its pose nearest the robot; infinite while the
        robot is more than oscillation_distance off the plan (moving about near a plan is not following it)."""
        if self.plan is None:
            return math.inf
        nearest = self._nearest_on_plan(pose)
        off = math.hypot(self.plan[nearest, 0] - pose[0], self.plan[nearest, 1] - pose[1])
        return float(self._plan_to_go[nearest]) if off <= self.cfg.oscillation_distance else math.inf

    def plan_remaining(self, pose) -> float | None:
        """Length still to drive along the current plan, from the robot to its nearest plan pose and on to the
        plan's end; None without a plan."""
        if self.plan is None:
            return None
        nearest = self._nearest_on_plan(pose)
        return float(self._plan_to_go[nearest] + math.hypot(self.plan[nearest, 0] - pose[0],
                                                            self.plan[nearest, 1] - pose[1]))

    def _check_plan(self, now: float, pose) -> str | None:
        """Send move_base back to PLANNING when the rest of the plan runs into a new obstacle."""
        if (self._plan_blocked is None or self.state != State.CONTROLLING or self.plan is None
                or now < self._last_blocked_replan + BLOCKED_REPLAN_INTERVAL_S):
            return None
        nearest = self._nearest_on_plan(pose)
        ahead = self.plan[nearest:]
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(ahead[:, :2], axis=0).T))])
        end = nearest + int(np.searchsorted(along, BLOCKED_CHECK_AHEAD_M, side="right"))
        new = self._plan_blocked(self.plan[nearest:end], pose) & ~self._blocked_at_plan[nearest:end]
        if not new.any():
            return None
        self.state = State.PLANNING
        self._last_valid_plan = now
        self._last_blocked_replan = now
        self._retries = 0
        x, y = self.plan[nearest + int(np.argmax(new)), :2]
        return f"the global plan now crosses an obstacle at ({x:.2f}, {y:.2f})"

    def _progress_since_recoveries(self) -> bool:
        return self._closest < self._progress_mark - self.cfg.oscillation_distance

    def _run_planner(self, now: float, pose) -> str:
        """Plan when PLANNING, or periodically while CONTROLLING; returns what happened."""
        periodic = self.cfg.planner_frequency > 0 and self.state == State.CONTROLLING and now >= self._next_plan_time
        if self.state != State.PLANNING and not periodic:
            return ""
        if self.cfg.planner_frequency > 0:
            self._next_plan_time = now + 1.0 / self.cfg.planner_frequency
        plan = self._plan(pose, self.goal)
        if not isinstance(plan, str) and len(plan):
            self._last_valid_plan = now
            self._retries = 0
            if not self.controller.set_plan(plan):
                self.reset()
                return "Failed to pass global plan to the controller, aborting."
            before = self._plan_left(pose)
            self.plan = plan
            steps = np.hypot(*np.diff(plan[:, :2], axis=0).T)
            self._plan_to_go = np.concatenate([np.cumsum(steps[::-1])[::-1], [0.0]])
            self._plan_made_at = now
            after = self._plan_left(pose)
            # Progress along plans is driven, not planned: a shortcut (through cells grazing rays erased from
            # a table's edge) lowers the mark without counting, a longer route leaves it where it was, and a
            # replan of about the same length keeps the count of a robot creeping along it.
            if self._best_to_go == math.inf or after < before - self.cfg.oscillation_distance:
                self._best_to_go = min(self._best_to_go, after)
            self._blocked_at_plan = (self._plan_blocked(plan, pose) if self._plan_blocked is not None
                                     else np.zeros(len(plan), dtype=bool))
            if self.trigger == Trigger.PLANNING_R and self._progress_since_recoveries():
                self.recovery_index = 0
            self.events.plan(now, f"{len(plan)} poses")
            if self.state == State.PLANNING:
                self.state = State.CONTROLLING
            return f"new plan with {len(plan)} poses"
        self.last_plan_failure = plan if isinstance(plan, str) else "the planner returned an empty plan"
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
        stalled = now - self._progress_time
        if self.cfg.progress_timeout > 0 and stalled > self.cfg.progress_timeout \
                and self._progress_distance >= self.cfg.oscillation_distance:
            self.state = State.CLEARING
            self.trigger = Trigger.PROGRESS_R
            return CycleOutput((0.0, 0.0), message=f"no progress towards the goal for {stalled:.0f} s "
                                                   f"(closest {self._closest:.2f} m)")
        result = self.controller.compute()
        if result.ok:
            self._last_valid_control = now
            if self.trigger == Trigger.CONTROLLING_R and self._progress_since_recoveries():
                self.recovery_index = 0
            return CycleOutput((result.v, result.omega))
        if now > self._last_valid_control + self.cfg.controller_patience:
            self.state = State.CLEARING
            self.trigger = Trigger.CONTROLLING_R
            return CycleOutput((0.0, 0.0), message=f"controller failed for {self.cfg.controller_patience:g} s: "
                                                   f"{result.message}")
        message = f"The local planner could not find a valid plan: {result.message}"
        if now < self._plan_made_at + MIN_REPLAN_INTERVAL_S:
            return CycleOutput((0.0, 0.0), message=f"{message} (keeping the global plan of "
                                                   f"{now - self._plan_made_at:.1f} s ago)")
        self.state = State.PLANNING
        self._last_valid_plan = now
        self._retries = 0
        return CycleOutput((0.0, 0.0), message=message)

    def _clear(self, now: float, pose) -> CycleOutput:
        if self._active_recovery is None:
            if not (self.cfg.recovery_behavior_enabled and self.recovery_index < len(self.recoveries)):
                message = ABORT_MESSAGES[self.trigger]
                if self.trigger == Trigger.PLANNING_R and self.last_plan_failure:
                    message += f" Last planner failure: {self.last_plan_failure}"
                cause = self.trigger.value
                self.reset()
                return CycleOutput((0.0, 0.0), outcome="aborted", message=message, cause=cause)
            if self.recovery_index == 0:
                self._progress_mark = self._closest
            self._active_recovery = self.recoveries[self.recovery_index]
            self._active_recovery.start(now, pose)
            which = (f"{self._active_recovery.name} ({self.recovery_index + 1}/{len(self.recoveries)}) "
                     f"after {self.trigger.value}")
            self.events.recovery(now, self._active_recovery.name, which)
            started = f"executing recovery behavior {which}"
        else:
            started = ""
        step = self._active_recovery.tick(now, pose)
        if not step.done:
            return CycleOutput(step.cmd, event=started)
        self._active_recovery = None
        self._oscillation_time = self._progress_time = now
        self._oscillation_pose = (pose[0], pose[1])
        self._last_valid_plan = now
        self._retries = 0
        self.state = State.PLANNING
        self.recovery_index += 1
        return CycleOutput(step.cmd if step.cmd is not None else (0.0, 0.0),
                           event="; ".join(m for m in (started, step.message) if m))
