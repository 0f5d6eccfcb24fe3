"""What move_base has done: counters and a short history of events.

The scenario runner, the viewer (through move_base's diagnostics) and the tests read this instead
of move_base's internals or its log text. Memory is bounded: counters, and the last
EVENT_HISTORY events.
"""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass, field

#: events kept for inspection (a recovery sequence and the goals around it fit)
EVENT_HISTORY = 32


@dataclass(frozen=True)
class NavigationEvent:
    stamp: float     # node clock, seconds
    kind: str        # "goal", "plan", "recovery", "handover" or a goal outcome ("succeeded", "aborted", "preempted")
    detail: str = ""


@dataclass(frozen=True)
class MoveBaseStats:
    """A copy of the counters at one moment; differences of two give what happened in between."""
    goals: int = 0
    replans: int = 0
    recoveries: int = 0
    recoveries_by_name: dict[str, int] = field(default_factory=dict)
    outcomes: dict[str, int] = field(default_factory=dict)
    recent: tuple[NavigationEvent, ...] = ()
    handovers: dict[str, int] = field(default_factory=dict)   # local planner type -> times it took over

    def handovers_since(self, before: MoveBaseStats) -> dict[str, int]:
        """Local planner type -> how often it took over after ``before``."""
        return {key: n - before.handovers.get(key, 0) for key, n in self.handovers.items()
                if n > before.handovers.get(key, 0)}

    def last(self, kind: str) -> NavigationEvent | None:
        """The newest kept event of a kind."""
        return next((e for e in reversed(self.recent) if e.kind == kind), None)


class MoveBaseEvents:
    """Counters and the recent history, written by the move_base core and node."""

    def __init__(self, history: int = EVENT_HISTORY):
        self.goals = 0
        self.replans = 0
        self.recoveries: Counter[str] = Counter()     # by behaviour name
        self.outcomes: Counter[str] = Counter()
        self.handovers: Counter[str] = Counter()      # by the local planner that took over (planner_switch.py)
        self.recent: deque[NavigationEvent] = deque(maxlen=history)

    def goal(self, now: float, detail: str = "") -> None:
        self.goals += 1
        self.recent.append(NavigationEvent(now, "goal", detail))

    def plan(self, now: float, detail: str = "") -> None:
        self.replans += 1
        self.recent.append(NavigationEvent(now, "plan", detail))

    def recovery(self, now: float, name: str, detail: str = "") -> None:
        self.recoveries[name] += 1
        self.recent.append(NavigationEvent(now, "recovery", detail or name))

    def handover(self, now: float, planner: str, detail: str = "") -> None:
        self.handovers[planner] += 1
        self.recent.append(NavigationEvent(now, "handover", detail or planner))

    def outcome(self, now: float, outcome: str, detail: str = "") -> None:
        self.outcomes[outcome] += 1
        self.recent.append(NavigationEvent(now, outcome, detail))

    def snapshot(self) -> MoveBaseStats:
        return MoveBaseStats(self.goals, self.replans, sum(self.recoveries.values()), dict(self.recoveries),
                             dict(self.outcomes), tuple(self.recent), dict(self.handovers))
