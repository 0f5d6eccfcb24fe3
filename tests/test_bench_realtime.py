"""bench/realtime.py's command line, without running anything: a forest of the benchmark set at a top speed, the
lab's tour, and the values it refuses."""

import math

import pytest

from simplebot_navigation.sim.world_loader import load_world

BENCH = "realtime"          # the conftest's bench fixture loads bench/realtime.py
FOREST = ["--world", "forest:3", "--arg", "robot:=round", "--arg", "radius:=0.25", "--arg", "tight:=true"]


def test_a_forest_at_2_m_s_drives_from_its_start_to_its_exit_at_the_derived_speed(bench):
    plan = bench.plan(FOREST + ["--arg", "max_speed:=2.0", "--stress", "0"])
    world = load_world("forest:3")
    assert [(g.name, g.x, g.y) for g in plan.goals] == [("exit", world.goal("exit").x, world.goal("exit").y)]
    assert plan.world.start == world.start
    assert plan.max_vel_x == 2.0 and plan.period_ms == 50.0
    assert plan.time_budget is None and plan.stress == 0
    (version,) = plan.versions
    assert version.world == "forest:3"
    assert version.launch_args == ("robot:=round", "radius:=0.25", "tight:=true", "max_speed:=2.0")
    assert plan.speed_report[0].startswith("max_speed 2 m/s: TebLocalPlannerROS.max_vel_x=2")


def test_an_explicit_set_wins_over_max_speed_and_goes_to_the_launcher(bench):
    plan = bench.plan(FOREST + ["--arg", "max_speed:=1.0", "--set", "TebLocalPlannerROS.max_vel_x=0.8",
                                   "--time-budget", "100", "--without-monitor"])
    assert plan.max_vel_x == 0.8 and plan.time_budget == 100.0
    assert "--set TebLocalPlannerROS.max_vel_x=0.8 replaces max_speed's 1" in plan.speed_report
    current, without = plan.versions
    assert current.launch_args[-1] == "--set=TebLocalPlannerROS.max_vel_x=0.8"
    assert without.launch_args[-1] == "collision_monitor:=false" and without.domain == current.domain + 1


def test_the_lab_tour_stays_the_default(bench):
    plan = bench.plan([])
    assert plan.versions[0].world == "lab" and plan.versions[0].launch_args == ()
    assert [g.name for g in plan.goals] == [g.name for g in load_world("lab").goals]
    assert plan.max_vel_x == 0.4 and plan.speed_report == [] and plan.stress == 2


@pytest.mark.parametrize("argv, message", [
    (FOREST + ["--goals", "kitchen"], "no goal named 'kitchen'"),
    (FOREST + ["--arg", "max_speed:=3.0"], "max_speed must be a number of m/s in [0.1, 2]"),
    (["--arg", "max_speed:=2.0"], "above the box's top speed of 1.05 m/s"),   # the lab's box keeps its drive
    (FOREST + ["--time-budget", "0"], "--time-budget must be a positive number"),
    (FOREST + ["--time-budget", str(math.nan)], "--time-budget must be a positive number"),
    (FOREST + ["--arg", "max_speed=2.0"], "expected NAME:=VALUE"),
    (FOREST + ["--arg", "world:=lab"], "use --world"),
    (["--world", "forest:x"], "unknown world"),
    (["--stress", "-1"], "--stress must be >= 0"),
])
def test_bad_values_are_refused_before_anything_starts(bench, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_info:
        bench.plan(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
