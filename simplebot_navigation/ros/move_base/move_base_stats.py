"""move_base's counters on ROS: goal outcomes by actionlib status, and the diagnostics statuses that
carry the counters and the control loop's timing to other processes (the viewer shows recoveries from
them, bench/realtime.py the cycle times)."""

from __future__ import annotations

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from simplebot_navigation.move_base.cycle_stats import CycleSnapshot
from simplebot_navigation.move_base.events import MoveBaseStats

NAVIGATION_STATUS = "move_base: navigation"
#: the goal outcomes move_base counts, by actionlib status
OUTCOMES = {ActionlibStatus.SUCCEEDED: "succeeded", ActionlibStatus.ABORTED: "aborted",
            ActionlibStatus.PREEMPTED: "preempted"}


def navigation_status(stats: MoveBaseStats, hardware_id: str) -> DiagnosticStatus:
    """Counters since start, and the latest recovery as '<name> (<i>/<n>) after <trigger>'."""
    last_recovery = stats.last("recovery")
    values = {"goals": str(stats.goals), "replans": str(stats.replans), "recoveries": str(stats.recoveries),
              "last_recovery": last_recovery.detail if last_recovery else "",
              **{outcome: str(stats.outcomes.get(outcome, 0)) for outcome in OUTCOMES.values()},
              **{f"recoveries/{name}": str(count) for name, count in stats.recoveries_by_name.items()}}
    return DiagnosticStatus(name=NAVIGATION_STATUS, hardware_id=hardware_id,
                            message=f"{stats.goals} goals, {stats.replans} plans, {stats.recoveries} recoveries",
                            values=[KeyValue(key=k, value=v) for k, v in values.items()])


def control_loop_status(window: CycleSnapshot, total: CycleSnapshot, recent, frequency_hz: float,
                        hardware_id: str) -> DiagnosticStatus:
    """The cycles since the previous report (window) and since start (total); recent: their compute times."""
    def ms(seconds):
        return "-" if seconds is None else f"{seconds * 1e3:.1f}"

    p50, p95, longest = window.percentile_s(50), window.percentile_s(95), window.longest_s
    status = DiagnosticStatus(name="move_base: control loop", hardware_id=hardware_id)
    status.level = DiagnosticStatus.WARN if window.missed else DiagnosticStatus.OK
    status.message = (f"{window.cycles} cycles, p95 {ms(p95)} ms, {window.missed} missed the "
                      f"{1e3 / frequency_hz:.0f} ms period" if window.cycles else "idle")
    values = {"frequency_hz": f"{frequency_hz:g}", "cycles": str(window.cycles),
              "missed": str(window.missed), "p50_ms": ms(p50), "p95_ms": ms(p95), "max_ms": ms(longest),
              "cycles_total": str(total.cycles), "missed_total": str(total.missed),
              "cycle_times_ms": " ".join(f"{t * 1e3:.2f}" for t in recent)}
    status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
    return status
