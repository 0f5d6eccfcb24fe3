import pytest

from simplebot_navigation.move_base.cycle_stats import ControlLoopStats


def test_percentiles_and_missed_cycles_of_one_stretch_of_the_run():
    stats = ControlLoopStats(period_s=0.05)
    for _ in range(100):
        stats.add(0.004)
    before = stats.snapshot()
    times = [0.002] * 90 + [0.030] * 8 + [0.060, 0.120]
    missed = [stats.add(t) for t in times]
    stretch = stats.snapshot().since(before)
    assert missed.count(True) == 2
    assert stretch.cycles == 100 and stretch.missed == 2
    assert stretch.missed_fraction == pytest.approx(0.02)
    assert stretch.percentile_s(50) == pytest.approx(0.0021)     # upper edge of the 0.1 ms bin
    assert stretch.percentile_s(95) == pytest.approx(0.0301)
    assert stretch.longest_s == pytest.approx(0.1201)
    whole = stats.snapshot().since(None)
    assert whole.cycles == 200 and whole.percentile_s(50) == pytest.approx(0.0041)


def test_memory_stays_bounded_over_a_long_run():
    stats = ControlLoopStats(period_s=0.05)
    for k in range(100_000):
        stats.add(0.001 * (k % 7))
    assert len(stats.take_recent()) <= 80                       # a few seconds' worth, not 100 000
    assert stats.take_recent() == []
    assert stats.snapshot().histogram.nbytes < 64_000


def test_a_cycle_longer_than_the_histogram_keeps_its_exact_maximum():
    stats = ControlLoopStats(period_s=0.05)
    stats.add(0.003)
    stats.add(2.5)
    snap = stats.snapshot()
    assert snap.longest_s == pytest.approx(2.5)
    assert snap.percentile_s(100) == pytest.approx(2.5)
    assert ControlLoopStats(0.05).snapshot().percentile_s(95) is None


def test_periods_in_which_no_cycle_ran_count_as_missed_while_the_loop_is_starved():
    """The control timer (node clock) stops being called while the housekeeping (steady clock) goes on: the
    missed periods show at once, not only when the loop runs again, and are counted once."""
    stats = ControlLoopStats(period_s=0.05)
    now = 100.0
    for k in range(40):                                   # 2 s at rate, housekeeping every other period
        stats.ran(now + 0.05 * k)
        if k % 2:
            stats.account(now + 0.05 * k + 0.049)
    assert stats.snapshot().missed == 0
    starved = stats.snapshot()
    for k in range(1, 11):                                # 1 s without a cycle
        stats.account(now + 1.95 + 0.1 * k)
    assert 18 <= stats.snapshot().since(starved).missed <= 20
    stats.ran(now + 3.0)                                  # the loop runs again: nothing counted twice
    for k in range(1, 21):
        stats.ran(now + 3.0 + 0.05 * k)
        stats.account(now + 3.0 + 0.05 * k + 0.01)
    assert 18 <= stats.snapshot().since(starved).missed <= 20


def test_time_jumping_back_or_a_new_period_starts_the_count_again():
    stats = ControlLoopStats(period_s=0.05)
    stats.ran(50.0)
    stats.ran(0.0)                                        # the simulator restarted
    stats.account(0.04)
    stats.set_period(0.1)
    stats.ran(0.05)
    stats.account(0.1)
    assert stats.snapshot().missed == 0

