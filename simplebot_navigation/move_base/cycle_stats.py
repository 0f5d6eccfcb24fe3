"""Control-loop timing with bounded memory, for diagnostics and the scenario runner.

A histogram of cycle times (0.1 ms bins) instead of a list of samples: a robot that runs for days
keeps a fixed few kilobytes, and the percentiles of any stretch of the run (one goal, one second)
are those of the difference of two snapshots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BIN_S = 1e-4
#: cycles longer than this share the last bin (their exact maximum is kept apart)
HISTOGRAM_SPAN_S = 0.5


@dataclass(frozen=True)
class CycleSnapshot:
    """Cumulative counts up to one moment; subtract an earlier one to describe the time between."""

    histogram: np.ndarray
    missed: int
    max_s: float

    @property
    def cycles(self) -> int:
        return int(self.histogram.sum())

    def since(self, earlier: "CycleSnapshot | None") -> "CycleSnapshot":
        if earlier is None:
            return self
        return CycleSnapshot(self.histogram - earlier.histogram, self.missed - earlier.missed, self.max_s)

    def percentile_s(self, q: float) -> float | None:
        """The q-th percentile, rounded up to the bin edge (None without cycles)."""
        total = self.cycles
        if total == 0:
            return None
        rank = max(1, int(np.ceil(q / 100.0 * total)))
        return self._bin_edge(int(np.searchsorted(np.cumsum(self.histogram), rank)))

    @property
    def longest_s(self) -> float | None:
        filled = np.flatnonzero(self.histogram)
        return self._bin_edge(int(filled[-1])) if len(filled) else None

    def _bin_edge(self, index: int) -> float:
        return self.max_s if index == len(self.histogram) - 1 else (index + 1) * BIN_S

    @property
    def missed_fraction(self) -> float:
        total = self.cycles
        return self.missed / total if total else 0.0


class ControlLoopStats:
    """Cycle times of move_base's control loop. A period is missed when its cycle computes longer than the period
    (the robot then runs on an older command) or when no cycle runs in it at all (the executor was busy elsewhere):
    ``ran(now)`` at every timer call, ``account(now)`` from a timer that keeps running (the housekeeping), so the
    missed periods show while the loop is starved, not only once it runs again."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self._histogram = np.zeros(int(round(HISTOGRAM_SPAN_S / BIN_S)), dtype=np.int64)
        self._missed = 0
        self._max_s = 0.0
        self._recent: list[float] = []        # since the last take_recent(), bounded
        self._recent_cap = max(16, int(4.0 / period_s))
        self._since: float | None = None      # the first timer call the periods are counted from
        self._calls = 0                       # timer calls since then, that one included
        self._skipped = 0                     # periods without a call since then, counted in _missed

    def set_period(self, period_s: float) -> None:
        """A new controller_frequency: later cycles are judged against this period."""
        self.period_s = period_s
        self._recent_cap = max(16, int(4.0 / period_s))
        self._since = None

    def ran(self, now_s: float) -> None:
        """The control timer called (with or without a goal) at node time now_s."""
        if self._since is None or now_s < self._since:          # the first call, or time jumped back
            self._since, self._calls, self._skipped = now_s, 0, 0
        self._calls += 1

    def account(self, now_s: float) -> None:
        """Count the periods up to now_s in which the timer did not call, as missed. The period just due may be
        on its way, so it is not counted yet."""
        if self._since is None or now_s < self._since:
            return
        due = int((now_s - self._since) / self.period_s + 1e-6) + 1      # calls due so far, the first included
        skipped = due - 1 - self._calls
        if skipped > self._skipped:
            self._missed += skipped - self._skipped
            self._skipped = skipped

    def add(self, seconds: float) -> bool:
        """Record one cycle; True when it missed the period."""
        index = min(int(seconds / BIN_S), len(self._histogram) - 1)
        self._histogram[index] += 1
        self._max_s = max(self._max_s, seconds)
        missed = seconds > self.period_s
        self._missed += missed
        if len(self._recent) < self._recent_cap:
            self._recent.append(seconds)
        return missed

    def snapshot(self) -> CycleSnapshot:
        return CycleSnapshot(self._histogram.copy(), self._missed, self._max_s)

    def take_recent(self) -> list[float]:
        """The cycle times since the previous call (the first ones, when more than a few seconds' worth)."""
        recent, self._recent = self._recent, []
        return recent
