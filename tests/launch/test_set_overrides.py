"""--set NAME=VALUE: move_base parameters from the command line, checked like the parameter files, and what the
robot then does with them."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D

REPO = Path(__file__).resolve().parents[2]


def print_params(*sets: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", "navigation", "--print-params",
                           *(f"--set={s}" for s in sets)], cwd=REPO, capture_output=True, text=True, timeout=120)


def test_set_values_reach_move_base_and_print_params_shows_them():
    done = print_params("TebLocalPlannerROS.max_vel_x=0.8", "local_costmap.inflation_layer.inflation_radius=0.3")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "# --set TebLocalPlannerROS.max_vel_x=0.8 --set local_costmap.inflation_layer.inflation_radius=0.3" in lines
    assert "TebLocalPlannerROS.max_vel_x: 0.8" in lines
    assert "local_costmap.inflation_layer.inflation_radius: 0.3" in lines
    assert "global_costmap.inflation_layer.inflation_radius: 1.5" in lines      # the other costmap keeps its own


def test_the_limits_of_nav2s_behaviours_are_move_base_parameters():
    done = print_params("behavior_server.max_rotational_vel=0.5", "behavior_server.simulate_ahead_time=1")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "behavior_server.max_rotational_vel: 0.5" in lines and "behavior_server.simulate_ahead_time: 1.0" in lines


@pytest.mark.parametrize("assignment, message", [
    ("TebLocalPlannerROS.max_vel_x=.nan", "TebLocalPlannerROS.max_vel_x"),
    ("TebLocalPlannerROS.max_vel_x=fast", "expected a number, got 'fast'"),
    ("TebLocalPlannerROS.max_vel=1", "did you mean 'TebLocalPlannerROS.max_vel_y'"),
    ("local_costmap.inflation_layer.inflation_radius=-1", "local_costmap.inflation_layer.inflation_radius"),
    ("behavior_server.max_rotational_vel=9", "behavior_server.max_rotational_vel: must be in (0, 6], got 9.0"),
    ("max_vel_x", "expected NAME=VALUE"),
])
def test_a_bad_set_is_one_line_naming_it(assignment, message):
    done = print_params(assignment)
    assert done.returncode == 2
    assert message in done.stderr and "--set" in done.stderr and "Traceback" not in done.stderr, done.stderr


@pytest.mark.timeout(300)
def test_a_lower_max_vel_x_slows_the_robot_down():
    with NavigationSession("empty", overrides=("TebLocalPlannerROS.max_vel_x=0.2",)) as session:
        session.wait_ready(wall_timeout_s=120.0)
        assert session.controller_param("max_vel_x", 0.4) == pytest.approx(0.2)
        start = session.pose()
        run = session.send_goal(Pose2D(start.x + 2.5, start.y, start.yaw))
        session.run_until(session.time + 60.0, lambda: run.done, wall_timeout_s=240.0)
        assert run.status == "SUCCEEDED", run.reason
        truth = np.array(session.truth_since(run.sent_at))
        speeds = np.hypot(np.diff(truth[:, 1]), np.diff(truth[:, 2])) / np.maximum(np.diff(truth[:, 0]), 1e-9)
        top = float(np.percentile(speeds, 99))
        assert 0.1 < top <= 0.2 * 1.1, f"99th-percentile speed {top:.3f} m/s with max_vel_x 0.2"
        assert math.isclose(session.pose().x, start.x + 2.5, abs_tol=0.3)


def test_max_speed_derives_the_speed_parameters_and_an_explicit_set_wins():
    done = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", "navigation", "robot:=round",
                           "--max-speed", "2.0", "--set=TebLocalPlannerROS.max_vel_theta=1.5", "--print-params"],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "TebLocalPlannerROS.max_vel_x: 2.0" in lines and "TebLocalPlannerROS.dt_ref: 0.15" in lines
    assert "local_costmap.width: 6" in lines and "controller_frequency: 20.0" in lines
    assert "TebLocalPlannerROS.max_vel_theta: 1.5" in lines                   # the explicit --set, not 2.0
    assert "# --set TebLocalPlannerROS.max_vel_theta=1.5 replaces max_speed's 2" in lines
    assert any(line.startswith("# max_speed 2 m/s: TebLocalPlannerROS.max_vel_x=2") for line in lines)


@pytest.mark.parametrize("value, message", [("3", "max_speed must be a number of m/s in [0.1, 2]"),
                                            ("fast", "max_speed:='fast' is not a number")])
def test_a_bad_max_speed_is_one_line(value, message):
    done = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", "navigation", f"max_speed:={value}",
                           "--print-params"], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and message in done.stderr and len(done.stderr.strip().splitlines()) == 1
