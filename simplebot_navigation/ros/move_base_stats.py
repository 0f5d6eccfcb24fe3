"""move_base's counters on ROS: goal outcomes by actionlib status, and the diagnostics status that
carries the counters to other processes (the viewer shows recoveries from it)."""

from __future__ import annotations

from actionlib_msgs.msg import GoalStatus as ActionlibStatus
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

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
