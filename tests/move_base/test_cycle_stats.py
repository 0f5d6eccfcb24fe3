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
