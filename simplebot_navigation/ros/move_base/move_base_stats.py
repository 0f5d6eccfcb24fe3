"""move_base's counters on ROS: goal outcomes by actionlib status, and the diagnostics statuses that
carry the counters and the control loop's timing to other processes (the viewer shows recoveries from
them, bench/realtime.py the cycle times)."""

from __future__ import annotations

from actionlib_msgs.msg import GoalStatus as ActionlibStatus, GoalStatusArray
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from simplebot_navigation.move_base.cycle_stats import CycleSnapshot
from simplebot_navigation.move_base.events import MoveBaseStats
from simplebot_navigation.ros.move_base.goal_arbiter import OUTCOMES

NAVIGATION_STATUS = "move_base: navigation"
#: a finished goal stays in /move_base/status this long (wall seconds)
FINISHED_STATUS_KEEP_S = 5.0


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
    """The cycles since the previous report (window) and since start (total); recent: their compute times. missed:
    periods whose cycle overran, or in which none ran (the loop starved), whether a goal was active or not."""
    def ms(seconds):
        return "-" if seconds is None else f"{seconds * 1e3:.1f}"

    p50, p95, longest = window.percentile_s(50), window.percentile_s(95), window.longest_s
    status = DiagnosticStatus(name="move_base: control loop", hardware_id=hardware_id)
    status.level = DiagnosticStatus.WARN if window.missed else DiagnosticStatus.OK
    if window.cycles:
        status.message = (f"{window.cycles} cycles, p95 {ms(p95)} ms, {window.missed} periods of "
                          f"{1e3 / frequency_hz:.0f} ms missed")
    else:
        status.message = f"idle, {window.missed} periods of {1e3 / frequency_hz:.0f} ms without a cycle" \
            if window.missed else "idle"
    values = {"frequency_hz": f"{frequency_hz:g}", "cycles": str(window.cycles),
              "missed": str(window.missed), "p50_ms": ms(p50), "p95_ms": ms(p95), "max_ms": ms(longest),
              "cycles_total": str(total.cycles), "missed_total": str(total.missed),
              "cycle_times_ms": " ".join(f"{t * 1e3:.2f}" for t in recent)}
    status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
    return status


class MoveBaseReports:
    """``~/status`` (the active goal and those finished lately, for users of the simple goal topic) and
    ``/diagnostics`` of a move_base node, published by its housekeeping timer and whenever a goal ends.

    It gets the two publishers, the node's clock and name, the GoalArbiter, the control loop's ControlLoopStats,
    the state machine's events and the configuration (controller_frequency, read live)."""

    def __init__(self, status_pub, diagnostics_pub, clock, name: str, arbiter, cycle_stats, events, cfg):
        self.status_pub, self.diagnostics_pub = status_pub, diagnostics_pub
        self._clock, self._name, self._arbiter = clock, name, arbiter
        self._cycle_stats, self._events, self._cfg = cycle_stats, events, cfg
        self._diagnostics_snapshot = cycle_stats.snapshot()
        arbiter.listen(on_end=lambda _goal: self.publish_status())

    def publish_status(self) -> None:
        arbiter = self._arbiter
        arbiter.forget_finished(FINISHED_STATUS_KEEP_S)
        msg = GoalStatusArray()
        msg.header.stamp = self._clock.now().to_msg()
        for goal in arbiter.finished + ([arbiter.active] if arbiter.active is not None else []):
            status = ActionlibStatus(status=goal.status, text=goal.text)
            status.goal_id.id = goal.id
            status.goal_id.stamp = goal.stamp
            msg.status_list.append(status)
        self.status_pub.publish(msg)

    def publish_diagnostics(self) -> None:
        """Control-loop timing and navigation counters once a second (steady clock, so it reports even when
        /clock stops)."""
        snapshot = self._cycle_stats.snapshot()
        window, self._diagnostics_snapshot = snapshot.since(self._diagnostics_snapshot), snapshot
        msg = DiagnosticArray(status=[
            control_loop_status(window, snapshot, self._cycle_stats.take_recent(), self._cfg.controller_frequency,
                                self._name),
            navigation_status(self._events.snapshot(), self._name)])
        msg.header.stamp = self._clock.now().to_msg()
        self.diagnostics_pub.publish(msg)
