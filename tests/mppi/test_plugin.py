"""MPPILocalPlannerROS as move_base runs it: selected by type name, its parameters in move_base's tree, following
max_speed, selectable from a campaign's parameter set, and driving a goal."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from simplebot_navigation.move_base.parameter_tree import parameter_table
from simplebot_navigation.move_base.plugins import LOCAL_PLANNERS
from simplebot_navigation.move_base.speed_profile import speed_parameters
from simplebot_navigation.mppi.plugin import MPPI_LOCAL_PLANNER
from simplebot_navigation.ros.move_base.mppi_local_planner_ros import MPPILocalPlannerROS
from simplebot_navigation.scenarios.campaign.spec import plan, spec_from_dict
from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D

SELECT = f"base_local_planner={MPPI_LOCAL_PLANNER}"
REPO = Path(__file__).resolve().parents[2]


def test_its_namespace_is_in_the_parameter_tree_when_it_drives_at_all():
    assert MPPI_LOCAL_PLANNER in LOCAL_PLANNERS.types
    for tree in ({"base_local_planner": MPPI_LOCAL_PLANNER}, {}):      # selected, or the crowd planner (default)
        assert {"MPPILocalPlannerROS.batch_size", "MPPILocalPlannerROS.vx_max",
                "MPPILocalPlannerROS.ax_min"} <= set(parameter_table(tree))
    assert not any(name.startswith("MPPILocalPlannerROS.") for name in parameter_table({"crowd_local_planner": ""}))


def test_max_speed_sets_its_limits_and_leaves_teb_alone():
    derived = speed_parameters(1.0, False, MPPI_LOCAL_PLANNER)
    assert derived["MPPILocalPlannerROS.vx_max"] == 1.0 and derived["MPPILocalPlannerROS.ax_min"] < 0
    assert not any(name.startswith("TebLocalPlannerROS.") for name in derived)
    assert derived["controller_frequency"] == speed_parameters(1.0, False)["controller_frequency"]


def test_its_turn_limits_follow_the_drive():
    """The round body of radius 0.25 m has its wheels 0.36 m apart: at 1 m/s (the lab's drive, 1.05 m/s and
    1.75 m/s^2 at the rim) it can turn at 5.8 rad/s and spin up at 9.7 rad/s^2; at 2 m/s the Jackal drive's own yaw
    limits (4 rad/s, 8 rad/s^2) bind. The launch reads the separation from the robot's description."""
    lab = speed_parameters(1.0, False, MPPI_LOCAL_PLANNER, wheel_separation=0.36)
    assert lab["MPPILocalPlannerROS.wz_max"] == pytest.approx(5.833, abs=1e-3)
    assert lab["MPPILocalPlannerROS.az_max"] == pytest.approx(9.722, abs=1e-3)
    assert lab["MPPILocalPlannerROS.wheel_accel_max"] == 1.75 and lab["MPPILocalPlannerROS.wheel_separation"] == 0.36
    jackal = speed_parameters(2.0, False, MPPI_LOCAL_PLANNER, wheel_separation=0.36)
    assert (jackal["MPPILocalPlannerROS.wz_max"], jackal["MPPILocalPlannerROS.az_max"]) == (4.0, 8.0)
    assert jackal["MPPILocalPlannerROS.wheel_accel_max"] == 2.5
    unknown = speed_parameters(1.0, False, MPPI_LOCAL_PLANNER)
    assert "MPPILocalPlannerROS.az_max" not in unknown and "MPPILocalPlannerROS.wheel_separation" not in unknown
    done = subprocess.run([sys.executable, "-m", "simplebot_navigation.launch", "navigation", "robot:=round",
                           "radius:=0.25", "max_speed:=1.0", f"--set={SELECT}", "--print-params"],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "MPPILocalPlannerROS.wheel_separation: 0.36" in done.stdout.splitlines(), done.stdout[-2000:]


def test_a_campaign_parameter_set_selects_it():
    spec = spec_from_dict({"worlds": "crowd:0", "robots": ["round:0.25"],
                           "params": [f"tight max_speed=1.0 {SELECT} MPPILocalPlannerROS.batch_size=500"]})
    assert len(plan(spec)) == 1


def test_move_base_loads_it_by_type_name_and_drives_a_goal():
    with NavigationSession("empty", robot="round", overrides=(SELECT,)) as session:
        session.wait_ready(wall_timeout_s=120.0)
        move_base = session.move_base
        assert isinstance(move_base.controller, MPPILocalPlannerROS)
        assert move_base.get_parameter("MPPILocalPlannerROS.vx_max").value == 0.4
        start = session.pose()
        goal = Pose2D(start.x + 2.0, start.y + 1.0, math.pi / 2, "ahead")
        run = session.send_goal(goal)
        session.run_until(session.time + 60.0, lambda: run.done, wall_timeout_s=300.0)
        assert run.status == "SUCCEEDED", run.reason
        pose = session.pose()
        assert np.hypot(pose.x - goal.x, pose.y - goal.y) <= 0.2
        assert abs(math.remainder(pose.yaw - goal.yaw, math.tau)) <= 0.15
