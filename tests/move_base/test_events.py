"""move_base's counters and event history: bounded, and what the scenario runner and viewer read."""

from simplebot_navigation.move_base.events import MoveBaseEvents


def test_counters_and_the_latest_event_of_a_kind():
    events = MoveBaseEvents()
    events.goal(0.0, "g1")
    events.plan(0.1, "40 poses")
    events.recovery(5.0, "conservative_reset", "conservative_reset (1/3) after PLANNING_R")
    events.recovery(6.0, "rotate_recovery", "rotate_recovery (2/3) after PLANNING_R")
    events.recovery(9.0, "rotate_recovery", "rotate_recovery (2/3) after CONTROLLING_R")
    events.outcome(12.0, "succeeded", "Goal reached")
    stats = events.snapshot()
    assert (stats.goals, stats.replans, stats.recoveries) == (1, 1, 3)
    assert stats.recoveries_by_name == {"conservative_reset": 1, "rotate_recovery": 2}
    assert stats.outcomes == {"succeeded": 1}
    assert stats.last("recovery").detail == "rotate_recovery (2/3) after CONTROLLING_R"
    assert stats.last("aborted") is None


def test_history_is_bounded_and_snapshots_do_not_change_afterwards():
    events = MoveBaseEvents(history=4)
    for i in range(10):
        events.plan(float(i))
    before = events.snapshot()
    events.plan(10.0)
    assert [e.stamp for e in before.recent] == [6.0, 7.0, 8.0, 9.0]
    assert before.replans == 10 and events.snapshot().replans == 11
