"""move_base's decision logic with a scripted planner and controller (docs/reference.md §1.3, §1.5)."""

import math

import numpy as np
import pytest

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.recovery import RecoveryStep
from simplebot_navigation.move_base.recovery.clear_costmap import ClearCostmapRecovery
from simplebot_navigation.move_base.recovery.rotate import RotateRecovery
from simplebot_navigation.move_base.plugins import ControlResult
from simplebot_navigation.move_base.state_machine import ABORT_MESSAGES, MoveBaseCore, State, Trigger

PLAN = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])


class ScriptedController:
    def __init__(self, results=(), reached_after=None):
        self.results = list(results)
        self.reached_after = reached_after
        self.computes = 0
        self.plans = 0

    def set_plan(self, plan):
        self.plans += 1
        return True

    def compute(self):
        self.computes += 1
        return self.results.pop(0) if self.results else ControlResult(True, 0.3, 0.0)

    def is_goal_reached(self):
        return self.reached_after is not None and self.computes >= self.reached_after

    def reset(self):
        pass


class CountingRecovery:
    def __init__(self, name, log):
        self.name = name
        self.log = log

    def start(self, now, pose):
        self.log.append(self.name)

    def tick(self, now, pose):
        return RecoveryStep(None, True, f"{self.name} done")


def run(core, seconds, dt=0.05, pose=(0.0, 0.0, 0.0), current=True, start=0.0):
    outputs = []
    t = start
    while t < start + seconds - 1e-9:
        out = core.cycle(t, pose, current)
        outputs.append((t, out))
        if out.outcome:
            break
        t += dt
    return outputs


def make_core(plan=lambda start, goal: PLAN, controller=None, recoveries=None, plan_blocked=None, **cfg):
    config = MoveBaseConfig.from_params(cfg)
    log = []
    recoveries = recoveries if recoveries is not None else [
        CountingRecovery(b["name"], log) for b in config.recovery_behaviors]
    core = MoveBaseCore(config, recoveries, plan, controller or ScriptedController(), plan_blocked)
    core.set_goal((1.0, 0.0, 0.0), 0.0)
    return core, log


def test_plans_controls_and_succeeds():
    controller = ScriptedController(reached_after=10)
    core, _ = make_core(controller=controller)
    outputs = run(core, 5.0)
    t, last = outputs[-1]
    assert last.outcome == "succeeded"
    assert core.replans == 1 and controller.plans == 1
    assert all(out.cmd == (0.3, 0.0) for _, out in outputs[1:-1])
    assert core.state == State.IDLE and core.goal is None


def test_no_plan_clears_for_planner_patience_then_runs_every_recovery_then_aborts():
    core, log = make_core(plan=lambda start, goal: "no path to (1.000, 0.000)")
    outputs = run(core, 60.0)
    t, last = outputs[-1]
    assert last.outcome == "aborted"
    assert last.message == ABORT_MESSAGES[Trigger.PLANNING_R] + " Last planner failure: no path to (1.000, 0.000)"
    assert log == ["conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"]
    first_recovery = next(t for t, out in outputs if "conservative_reset" in out.event)
    assert first_recovery == pytest.approx(5.05, abs=0.051)     # planner_patience 5 s
    assert 4 * 5.0 < t < 4 * 5.0 + 5.5                           # patience again after every recovery


def test_max_planning_retries_short_circuits_the_patience():
    core, log = make_core(plan=lambda start, goal: "no path", max_planning_retries=2)
    outputs = run(core, 1.0)
    assert log[:1] == ["conservative_reset"]
    # the third failed plan (retries 3 > 2) starts the first recovery in the same cycle
    assert next(i for i, (_, out) in enumerate(outputs) if out.event) == 2


def test_failed_control_replans_once_a_second_not_every_cycle():
    controller = ScriptedController([ControlResult(False, message="no trajectory")] * 10_000)
    core, log = make_core(controller=controller, controller_patience=10.0)
    outputs = run(core, 9.9)
    assert log == []
    assert core.replans == 10                      # at 0, 1, ..., 9 s; 198 failed cycles in between
    kept = [out.message for _, out in outputs if "keeping the global plan" in out.message]
    assert len(kept) > 150 and all(out.cmd == (0.0, 0.0) for _, out in outputs[1:])


def test_failed_control_clears_after_controller_patience():
    failing = [ControlResult(False, message="no trajectory")] * 10_000
    controller = ScriptedController(failing)
    core, log = make_core(controller=controller, controller_patience=2.0)
    outputs = run(core, 30.0)
    first = next(t for t, out in outputs if out.event.startswith("executing recovery"))
    assert first == pytest.approx(2.1, abs=0.11)
    t, last = outputs[-1]
    assert last.outcome == "aborted" and last.message == ABORT_MESSAGES[Trigger.CONTROLLING_R]


def test_oscillation_timeout_triggers_recoveries_when_the_robot_does_not_move():
    core, log = make_core(oscillation_timeout=3.0, oscillation_distance=0.5)
    outputs = run(core, 30.0)
    t, last = outputs[-1]
    assert last.outcome == "aborted" and last.message == ABORT_MESSAGES[Trigger.OSCILLATION_R]
    assert log[0] == "conservative_reset"


def test_moving_robot_does_not_oscillate():
    core, log = make_core(oscillation_timeout=1.0, oscillation_distance=0.1)
    for i in range(100):
        out = core.cycle(i * 0.05, (i * 0.05 * 0.3, 0.0, 0.0), True)
        assert not out.outcome
    assert log == []


def test_stale_sensors_stop_the_robot_and_name_the_source():
    core, _ = make_core()
    out = core.cycle(0.0, (0.0, 0.0, 0.0), False, "local_costmap/obstacles/front_laser")
    assert out.cmd == (0.0, 0.0)
    assert "Sensor data is out of date" in out.message and "obstacles/front_laser" in out.message
    assert core.replans == 0


def test_a_new_plan_restarts_the_recovery_sequence_once_the_robot_gets_closer():
    answers = iter(["no path"] * 102 + [PLAN] * 1000)
    controller = ScriptedController([ControlResult(False)] * 1000)
    core, log = make_core(plan=lambda start, goal: next(answers), controller=controller, controller_patience=100.0)
    run(core, 6.0)                       # the goal is 1 m away
    assert log == ["conservative_reset"] and core.trigger == Trigger.PLANNING_R
    run(core, 0.2, start=6.0)            # plans again, but no nearer to the goal
    assert core.recovery_index == 1
    run(core, 1.2, start=6.2, pose=(0.55, 0.0, 0.0))    # 0.45 m: more than oscillation_distance (0.5) closer,
    assert core.recovery_index == 0                        # and a plan a second after the last one


def test_plans_that_keep_failing_near_an_unreachable_goal_end_in_an_abort():
    """Each recovery is followed by a plan that works for a while (cleared space), then fails again."""
    plans = []
    log = []

    def plan(start, goal):
        if len(plans) > len(log):   # one plan at the start and one after every recovery
            return "no path"
        plans.append(PLAN)
        blocked["now"] = False      # a new plan goes round what the sensors saw
        return PLAN

    blocked = {"now": False}
    core, _ = make_core(plan=plan, plan_blocked=lambda poses, robot: np.full(len(poses), blocked["now"]),
                        recoveries=[CountingRecovery(name, log) for name in ("conservative_reset", "rotate_recovery",
                                                                             "aggressive_reset", "rotate_recovery")])
    outputs = []
    for i in range(2000):
        blocked["now"] = i % 40 == 39   # the sensors see the obstacle again two seconds after every new plan
        out = core.cycle(i * 0.05, (0.0, 0.0, 0.0), True)
        outputs.append(out)
        if out.outcome:
            break
    assert outputs[-1].outcome == "aborted" and "Last planner failure: no path" in outputs[-1].message
    assert log == ["conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"]


STRAIGHT = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
AROUND = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [1.0, 0.0, 0.0]])


def on_cells(*cells):
    """plan_blocked marking the poses at the given (x, y)."""
    def plan_blocked(poses, robot):
        return np.array([any(np.allclose(p[:2], c) for c in cells) for p in poses], dtype=bool)
    return plan_blocked


def test_a_blocked_plan_is_replaced_in_the_same_cycle():
    answers = iter([STRAIGHT, AROUND])
    obstacle = []
    core, _ = make_core(plan=lambda start, goal: next(answers), plan_blocked=lambda p, r: on_cells(*obstacle)(p, r))
    first = core.cycle(0.0, (0.0, 0.0, 0.0), True)
    assert first.cmd == (0.3, 0.0) and core.replans == 1
    obstacle.append((0.5, 0.0))      # seen after planning
    second = core.cycle(0.05, (0.0, 0.0, 0.0), True)
    assert second.cmd == (0.3, 0.0) and core.replans == 2 and core.plan is AROUND
    assert second.event.startswith("the global plan now crosses an obstacle at (0.50, 0.00): replanning")


def test_a_plan_made_through_a_blocked_cell_is_not_replaced_for_it():
    """Next to a robot standing in an inflated zone the planner's own poses can lie on blocked cells:
    that crossing is not new, and replanning for it every cycle would only thrash."""
    core, _ = make_core(plan=lambda start, goal: STRAIGHT, plan_blocked=on_cells((0.5, 0.0)))
    outputs = [core.cycle(0.05 * i, (0.0, 0.0, 0.0), True) for i in range(40)]
    assert core.replans == 1 and all(out.cmd == (0.3, 0.0) for out in outputs)


def test_only_a_crossing_the_robot_will_reach_soon_replaces_the_plan():
    """A wall cell far ahead may be one that grazing rays erase and re-mark in turn: replanning for
    it would send the robot back and forth between two routes."""
    long_plan = np.column_stack([np.arange(0.0, 10.01, 0.1), np.zeros(101), np.zeros(101)])
    obstacle = [(6.0, 0.0)]
    core, _ = make_core(plan=lambda start, goal: long_plan, plan_blocked=lambda p, r: on_cells(*obstacle)(p, r))
    core.cycle(0.0, (0.0, 0.0, 0.0), True)
    obstacle.append((8.0, 0.0))
    core.cycle(0.05, (0.0, 0.0, 0.0), True)
    assert core.replans == 1                      # 8 m ahead: not yet
    out = core.cycle(0.10, (5.5, 0.0, 0.0), True)  # 2.5 m ahead now
    assert core.replans == 2 and out.event.startswith("the global plan now crosses an obstacle at (8.00, 0.00)")


def test_replans_for_new_obstacles_come_at_most_once_a_second():
    obstacle = []

    def plan(start, goal):
        obstacle.clear()              # the new plan avoids what was seen ...
        return STRAIGHT.copy()

    core, _ = make_core(plan=plan, plan_blocked=lambda p, r: on_cells(*obstacle)(p, r))
    core.cycle(0.0, (0.0, 0.0, 0.0), True)
    for i in range(1, 61):            # ... and every cycle the sensors see a new cell on it
        obstacle[:] = [(0.5, 0.0)]
        core.cycle(0.05 * i, (0.0, 0.0, 0.0), True)
    assert core.replans == 1 + 3      # at 0.05 s, 1.05 s and 2.05 s


def test_periodic_replanning_while_controlling():
    core, _ = make_core(planner_frequency=2.0)
    run(core, 5.0)
    assert core.replans == pytest.approx(10, abs=1)


@pytest.mark.parametrize("params, fragment", [
    ({"controller_frequency": "fast"}, "controller_frequency: expected a number"),
    ({"max_planning_retries": 1.5}, "max_planning_retries: expected an int"),
    ({"recovery_behavior_enabled": "yes"}, "recovery_behavior_enabled: expected true or false"),
])
def test_bad_parameters_are_named(params, fragment):
    with pytest.raises(ValueError, match=fragment):
        MoveBaseConfig.from_params(params)


def test_recovery_list_defaults_and_fallback():
    assert [b["name"] for b in MoveBaseConfig.from_params({}).recovery_behaviors] == [
        "conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"]
    no_rotation = MoveBaseConfig.from_params({"clearing_rotation_allowed": False})
    assert [b["name"] for b in no_rotation.recovery_behaviors] == ["conservative_reset", "aggressive_reset"]
    broken = MoveBaseConfig.from_params({"recovery_behaviors": [{"name": "x", "type": "no/Such"}]})
    assert len(broken.recovery_behaviors) == 4 and "using the default recovery behaviours" in broken.warnings[0]
    custom = MoveBaseConfig.from_params({"recovery_behaviors": [
        {"name": "reset", "type": "clear_costmap_recovery/ClearCostmapRecovery"}]})
    assert custom.recovery_behaviors == [{"name": "reset", "type": "clear_costmap_recovery/ClearCostmapRecovery"}]


def test_rotate_recovery_turns_a_full_circle_counter_clockwise():
    rotate = RotateRecovery("rotate_recovery", {}, lambda poses: True)
    yaw, t, dt = 0.3, 0.0, 0.05
    rotate.start(t, (0.0, 0.0, yaw))
    turned = 0.0
    for _ in range(1000):
        step = rotate.tick(t, (0.0, 0.0, yaw))
        if step.done:
            break
        assert step.cmd[0] == 0.0 and 0.4 <= step.cmd[1] <= 1.0
        yaw = math.remainder(yaw + step.cmd[1] * dt, 2 * math.pi)
        turned += step.cmd[1] * dt
        t += dt
    assert step.done and turned == pytest.approx(2 * math.pi, abs=0.1)


def test_rotate_recovery_stops_before_a_collision():
    rotate = RotateRecovery("rotate_recovery", {}, lambda poses: bool((poses[:, 2] < 1.0).all()))
    rotate.start(0.0, (0.0, 0.0, 0.0))
    step = rotate.tick(0.0, (0.0, 0.0, 0.0))
    assert step.done and "can't rotate in place because there is a potential collision" in step.message


def test_clear_costmap_recovery_clears_the_affected_maps():
    calls = []

    def clear(costmap, x, y, distance, layers, invert, force):
        calls.append((costmap, x, y, distance, layers, invert))
        return ["obstacles"]

    recovery = ClearCostmapRecovery("aggressive_reset", {"affected_maps": "local"},
                                    {"global": "G", "local": "L"}, clear, 1.84)
    recovery.start(0.0, (1.0, 2.0, 0.0))
    step = recovery.tick(0.0, (1.0, 2.0, 0.0))
    assert calls == [("L", 1.0, 2.0, 1.84, None, False)]
    assert step.done and "outside a 1.84 m square" in step.message


def test_a_robot_circling_without_getting_closer_runs_out_of_recoveries():
    core, log = make_core()
    core.set_goal((0.0, 0.0, 0.0), 0.0)
    outputs = []
    for i in range(6000):   # 300 s on a 2 m circle around the goal: moving, never closer
        t = i * 0.05
        out = core.cycle(t, (2.0 * math.cos(0.2 * t), 2.0 * math.sin(0.2 * t), 0.0), True)
        outputs.append((t, out))
        if out.outcome:
            break
    t, last = outputs[-1]
    assert last.outcome == "aborted" and last.message == ABORT_MESSAGES[Trigger.PROGRESS_R]
    assert log == ["conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"]
    first = next(t for t, out in outputs if out.message.startswith("no progress towards the goal"))
    lap = 2 * math.pi / 0.2       # every square metre on the circle is new during the first lap
    assert lap < first < lap + 30.1   # progress_timeout 30 s
    assert t == pytest.approx(first + 4 * 30.0, abs=0.5)


def test_a_robot_that_keeps_getting_closer_or_is_at_the_goal_makes_progress():
    core, log = make_core(progress_timeout=5.0)
    core.set_goal((30.0, 0.0, 0.0), 0.0)
    for i in range(1000):   # 50 s at 0.3 m/s straight at the goal, then 20 s turning in place at it
        t = i * 0.05
        assert not core.cycle(t, (min(0.3 * t, 29.7), 0.0, 0.0), True).outcome
    for i in range(400):
        assert not core.cycle(50.0 + i * 0.05, (29.7, 0.0, 0.01 * i), True).outcome
    assert log == []


def test_progress_timeout_zero_lets_the_robot_circle():
    core, log = make_core(progress_timeout=0.0)
    for i in range(2000):
        t = i * 0.05
        assert not core.cycle(t, (1.0 + 2.0 * math.cos(0.2 * t), 2.0 * math.sin(0.2 * t), 0.0), True).outcome
    assert log == []


def winding_plan() -> np.ndarray:
    """Rows 1.9 m long and 0.3 m apart, back and forth across the way to a goal 10 m to the north."""
    rows = []
    for k in range(4):
        xs = np.linspace(0.0, 1.9, 39)
        rows.append(np.column_stack([xs if k % 2 == 0 else xs[::-1], np.full(39, 0.3 * k), np.zeros(39)]))
    return np.vstack(rows + [[[0.0, 10.0, 0.0]]])


def along(plan: np.ndarray, s: float) -> tuple[float, float, float]:
    steps = np.hypot(*np.diff(plan[:, :2], axis=0).T)
    i = int(np.searchsorted(np.cumsum(steps), s))
    return float(plan[i + 1, 0]), float(plan[i + 1, 1]), 0.0


def test_creeping_along_a_winding_plan_is_progress_and_a_route_that_comes_and_goes_is_not():
    """At 0.05 m/s along rows across the way to the goal the robot gets no nearer and stays in two squares
    for 80 s: the plan left to drive is what shrinks. Plans that alternate with a longer route do not
    restart that count, so a robot circling where plans come and go still runs out of progress."""
    plan = winding_plan()
    core, log = make_core(plan=lambda start, goal: plan, planner_frequency=1.0, progress_timeout=30.0)
    core.set_goal((0.95, 10.0, 0.0), 0.0)
    for i in range(1600):
        assert not core.cycle(i * 0.05, along(plan, 0.0025 * i), True).outcome
    assert log == []

    longer = np.vstack([[[0.0, 0.0, 0.0], [-5.0, 0.0, 0.0], [-5.0, 10.0, 0.0]], plan[-1:]])
    for other in (longer, plan[[0, -1]]):        # a longer route, and a shortcut straight to the goal
        core_time = [0.0]
        core, log = make_core(plan=lambda start, goal: (plan, other)[int(core_time[0]) % 2], planner_frequency=1.0,
                              progress_timeout=30.0)
        core.set_goal((0.95, 10.0, 0.0), 0.0)
        for i in range(1600):            # back and forth along the first 0.6 m of the winding rows
            core_time[0] = i * 0.05
            core.cycle(i * 0.05, along(plan, 0.3 - 0.3 * math.cos(0.05 * i)), True)
        assert log[:1] == ["conservative_reset"]
