"""Who drives when (move_base/planner_switch.py): the base planner, the crowd planner while moving obstacles are
near, and each taking over afresh."""

import numpy as np
import pytest

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.parameter_tree import build_configs, crowd_planner, parameter_table
from simplebot_navigation.move_base.planner_switch import LocalPlannerSwitch, moving_obstacle_near
from simplebot_navigation.move_base.plugins import ControlResult
from simplebot_navigation.mppi.plugin import MPPI_LOCAL_PLANNER
from simplebot_navigation.teb.plugin import TEB_LOCAL_PLANNER


class Planner:
    """Records what the switch asks of it; drives a command of its own name's length."""

    def __init__(self, name):
        self.name, self.calls, self.plan = name, [], None

    def __getattr__(self, method):
        return lambda *args: self.calls.append((method, *args))

    def set_plan(self, plan):
        self.calls.append(("set_plan",))
        self.plan = plan
        return True

    def reset(self):
        self.calls.append(("reset",))
        self.plan = None

    def compute(self):
        return ControlResult(True, len(self.name), 0.0)


def switch(near_at=()):
    """A switch whose obstacles are near at the cycles listed, cycles 0.05 s apart."""
    clock = {"t": 0.0, "cycle": 0}
    base, crowd, lines = Planner("base"), Planner("crowd!"), []
    s = LocalPlannerSwitch(base, crowd, lambda pose: clock["cycle"] in near_at, MoveBaseConfig(),
                           lambda: clock["t"], lambda planner, why: lines.append(f"{planner}: {why}"),
                           ("teb", "mppi"))

    def cycle():
        s.begin_cycle((0.0, 0.0, 0.0, clock["t"]))
        out = s.compute()
        clock["t"] += 0.05
        clock["cycle"] += 1
        return out.v
    return s, base, crowd, lines, cycle


def test_the_base_planner_drives_while_nothing_moves_near():
    s, base, crowd, lines, cycle = switch()
    s.set_plan(np.zeros((3, 3)))
    assert [cycle() for _ in range(100)] == [4] * 100
    assert crowd.calls == [] and lines == [] and s.driving == "teb"


def test_the_crowd_planner_drives_while_obstacles_are_near_and_hands_back_after_the_release_time():
    s, base, crowd, lines, cycle = switch(near_at=set(range(10, 30)))
    plan = np.ones((4, 3))
    s.set_plan(plan)
    driven = [cycle() for _ in range(100)]
    release = round(MoveBaseConfig().crowd_release_time / 0.05)
    assert driven == [4] * 10 + [6] * (20 + release) + [4] * (70 - release)
    # each takes over afresh, with the plan of the goal
    assert crowd.calls[:2] == [("reset",), ("set_plan",)] and crowd.plan is plan
    assert ("reset",) in base.calls and base.plan is plan
    assert lines == ["mppi: moving obstacles near", "teb: no moving obstacle near for 2 s"]


def test_a_new_plan_goes_to_the_planner_that_drives_and_the_end_of_a_goal_resets_both():
    s, base, crowd, lines, cycle = switch(near_at={0})
    s.set_plan(np.zeros((2, 3)))
    cycle()
    s.set_plan(np.ones((2, 3)))
    assert crowd.plan[0, 0] == 1.0 and base.plan[0, 0] == 0.0
    s.reset()
    assert base.plan is None and crowd.plan is None and s.driving == "teb"
    s.set_controller_frequency(10.0)
    assert ("set_controller_frequency", 10.0) in base.calls and ("set_controller_frequency", 10.0) in crowd.calls


def test_without_a_crowd_planner_the_base_drives_whatever_moves():
    base = Planner("base")
    s = LocalPlannerSwitch(base, None, lambda pose: True, MoveBaseConfig(), lambda: 0.0, None)
    s.begin_cycle((0.0, 0.0, 0.0, 0.0))
    assert s.compute().v == 4 and s.driving == "base"


@pytest.mark.parametrize("row, near", [
    ([3.0, 0.0, 0.0, 0.0, 0.3], False),          # 2.4 m from the body, standing
    ([2.0, 0.0, 0.0, 0.0, 0.3], True),           # 1.4 m
    ([8.0, 0.0, -2.0, 0.0, 0.3], True),          # 8 m away, 2 s from the body at 2 m/s
    ([8.0, 0.0, 2.0, 0.0, 0.3], False),          # walking away
    ([3.0, 5.0, 0.0, -1.0, 0.3], False),         # crosses 2.4 m ahead: never within 1.5 m
    ([1.5, 4.0, 0.0, -1.0, 0.3], True),          # 1.2 m from the body at (1.5, 1.0), 3 s from now
    ([1.5, 5.0, 0.0, -1.0, 0.3], False),         # the same path a second later: 1.9 m off by then
])
def test_near_is_now_or_along_the_obstacles_path(row, near):
    assert moving_obstacle_near(np.array([row]), (0.0, 0.0), 0.3, 3.0, 1.5) is near
    assert moving_obstacle_near(np.zeros((0, 5)), (0.0, 0.0), 0.3, 3.0, 1.5) is False


def test_the_crowd_planner_has_its_namespace_unless_it_is_the_base_planner():
    tree = {"base_local_planner": TEB_LOCAL_PLANNER}
    assert crowd_planner(MoveBaseConfig.from_params(tree)) == MPPI_LOCAL_PLANNER
    table = parameter_table(tree)
    assert "MPPILocalPlannerROS.vx_max" in table and "TebLocalPlannerROS.max_vel_x" in table
    assert build_configs(tree).crowd_planner.limits.vx_max == 0.4
    for same in ({"base_local_planner": MPPI_LOCAL_PLANNER}, {"crowd_local_planner": ""}):
        assert crowd_planner(MoveBaseConfig.from_params(same)) is None
        assert build_configs(same).crowd_planner is None
    assert "MPPILocalPlannerROS.vx_max" not in parameter_table({"crowd_local_planner": ""})
