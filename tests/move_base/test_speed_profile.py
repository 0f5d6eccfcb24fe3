"""max_speed: every speed-dependent parameter derived from one number (docs/reference.md §10)."""

import math
from pathlib import Path

import pytest

from simplebot_navigation.move_base.speed_profile import (BAND_STEP_M, LIDAR_RANGE_M, MIN_DT_REF_S, check_speed,
                                                          speed_parameters, stopping_distance)

SPEEDS = (0.4, 0.7, 1.0, 1.5, 2.0)
#: what grows with the speed, and what shrinks
GROWS = ("TebLocalPlannerROS.max_vel_x", "TebLocalPlannerROS.max_vel_theta", "TebLocalPlannerROS.acc_lim_x",
         "TebLocalPlannerROS.acc_lim_theta", "TebLocalPlannerROS.max_vel_x_backwards", "local_costmap.width",
         "local_costmap.obstacles.front_laser.obstacle_range")
SHRINKS = ("TebLocalPlannerROS.dt_ref", "TebLocalPlannerROS.dt_hysteresis", "progress_timeout")


def test_the_one_metre_per_second_set_the_forests_were_tuned_with_comes_out():
    p = speed_parameters(1.0, viapoints_on=False)
    assert {k: p[f"TebLocalPlannerROS.{k}"] for k in ("max_vel_x", "acc_lim_x", "max_vel_theta", "acc_lim_theta",
                                                     "dt_ref", "dt_hysteresis")} == {
        "max_vel_x": 1.0, "acc_lim_x": 1.0, "max_vel_theta": 1.0, "acc_lim_theta": 1.0, "dt_ref": 0.15,
        "dt_hysteresis": 0.015}
    assert "TebLocalPlannerROS.global_plan_viapoint_sep" not in p


@pytest.mark.parametrize("name", GROWS + SHRINKS)
def test_each_derived_parameter_follows_the_speed(name):
    values = [speed_parameters(v, True)[name] for v in SPEEDS]
    pairs = list(zip(values, values[1:]))
    if name in GROWS:
        assert all(b >= a for a, b in pairs) and values[-1] > values[0], values
    else:
        assert all(b <= a for a, b in pairs) and values[-1] < values[0], values


@pytest.mark.parametrize("speed", SPEEDS)
def test_the_band_stays_fine_and_the_robot_can_stop_inside_what_it_sees(speed):
    p = speed_parameters(speed, True)
    dt_ref = p["TebLocalPlannerROS.dt_ref"]
    assert dt_ref >= MIN_DT_REF_S                   # the acceleration edges do not take over the band
    # poses no further apart than the thinnest posts where dt_ref allows, and always within the round body
    assert speed * dt_ref <= max(BAND_STEP_M, speed * MIN_DT_REF_S) + 1e-9 <= 2 * 0.15 + 1e-9
    stop = stopping_distance(speed, p["TebLocalPlannerROS.acc_lim_x"])
    sight = p["local_costmap.obstacles.front_laser.obstacle_range"]
    assert stop < sight <= LIDAR_RANGE_M and stop < p["local_costmap.width"] / 2
    checked = p["TebLocalPlannerROS.feasibility_check_no_poses"] * speed * dt_ref
    assert checked >= stop                           # TEB checks the band for collisions as far as it takes to stop
    assert isinstance(p["local_costmap.width"], int)  # costmap_2d's width is whole metres
    assert speed * 1.0 / p["controller_frequency"] <= 0.1 + 1e-9


@pytest.mark.parametrize("bad", [0.0, -1.0, 2.5, math.nan, math.inf, True, "1.0"])
def test_a_speed_outside_the_rules_is_refused(bad):
    assert "max_speed" in check_speed(bad)
    with pytest.raises(ValueError, match="max_speed"):
        speed_parameters(bad, False)


def test_reference_table_gives_the_derived_values():
    """docs/reference.md §10's table is the contract: each row's values at 0.4, 1.0, 1.5 and 2.0 m/s are what the
    rules derive (to the table's rounding)."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "reference.md").read_text()
    section = text[text.index("## 10. One speed setting"):text.index("## 11.")]
    header = next(line for line in section.splitlines() if line.startswith("| parameter | rule |"))
    speeds = [float(cell) for cell in header.strip("|").split("|")[2:]]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    checked = 0
    for row in rows:
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        names = [n.strip("` ") for n in cells[0].split(",")]
        for speed, cell in zip(speeds, cells[2:]):
            derived = speed_parameters(speed, viapoints_on=True)
            for name in names:
                name = name.replace("<laser>", "front_laser")
                key = next(k for k in derived if k.split(".", 1)[-1] == name.split(".", 1)[-1]
                           or k == f"local_costmap.{name}")
                assert float(derived[key]) == pytest.approx(float(cell), abs=0.006), (name, speed, derived[key], cell)
                checked += 1
    assert checked >= 13 * len(speeds)
