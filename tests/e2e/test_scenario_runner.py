"""The scenario runner's goals, budgets, measures and outputs; and the command itself on a short run."""

import dataclasses
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from simplebot_description import robot_description
from simplebot_navigation.scenarios.report import plot, table, write_json
from simplebot_navigation.scenarios.runner import (GoalResult, ScenarioOptions, min_clearance, parse_goals,
                                                   shortest_path_length, time_budget)
from simplebot_navigation.sim.moving import MovingObstacle
from simplebot_navigation.sim.world import Pose2D, world_from_dict
from simplebot_navigation.sim.world_loader import load_world

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LAB = load_world("lab")
WALL = world_from_dict({"name": "wall", "walls": [{"from": [1.05, -3.0], "to": [1.05, 3.0], "thickness": 0.1}],
                        "start": {"x": 0.0, "y": 0.0, "yaw": 0.0}})


def test_goals_from_the_world_file_by_name_and_by_coordinates():
    assert [g.name for g in parse_goals(None, LAB)] == ["nw_office", "meeting_north", "library", "open_plan",
                                                        "meeting_south", "lab"]
    goals = parse_goals("library,lab; 1.5,-2 ;3,4,1.57", LAB)
    assert [(g.x, g.y, g.yaw, g.name) for g in goals] == [
        (8.5, 5.0, 0.0, "library"), (10.5, -4.5, -1.5708, "lab"), (1.5, -2.0, 0.0, "(1.5, -2)"),
        (3.0, 4.0, 1.57, "(3, 4)")]


@pytest.mark.parametrize("text, message", [
    ("kitchen", "no goal named 'kitchen'; goals: nw_office, meeting_north"),
    ("1,2;;3,4", "empty item"),
    ("1,x", "'1,x' mixes numbers and names"),
    ("1,2,3,4", "'1,2,3,4' must be 'x,y' or 'x,y,yaw'"),
    ("1,nan", "with finite numbers"),
])
def test_bad_goals_are_named(text, message):
    with pytest.raises(ValueError, match=message):
        parse_goals(text, LAB)


def test_a_world_without_goals_needs_goals():
    with pytest.raises(ValueError, match="world 'wall' .* has no goals; give --goals"):
        parse_goals(None, WALL)


def test_budget_follows_the_way_through_the_doors():
    office = LAB.goal("nw_office")
    straight = math.hypot(office.x, office.y)
    length = shortest_path_length(LAB, LAB.start, office)
    # Along the corridor to the door at x = -8 and up: longer than the straight line, shorter than the L.
    assert straight + 1.0 < length < abs(office.x) + abs(office.y)
    assert time_budget(LAB, LAB.start, office, 0.4) == pytest.approx(20.0 + 2.0 * length / 0.4)
    outside = Pose2D(13.0, 0.0)  # beyond the lab's outer walls: no path, so the straight line
    assert shortest_path_length(LAB, LAB.start, outside) == pytest.approx(13.0)


def test_clearance_of_the_box_and_the_round_body():
    box, round_body = robot_description("box"), robot_description("round", 0.3)
    truth = np.array([[0.0, 0.0, 0.0, 0.0], [0.1, -0.5, 0.0, 0.0]])
    # The wall's face is at x = 1.0; the box's front edge at x = 0.45, the round body's at 0.3.
    assert min_clearance(WALL, box, truth) == pytest.approx(0.55)
    assert min_clearance(WALL, round_body, truth) == pytest.approx(0.7)
    # Turned by 90 degrees the box reaches only 0.3 forward.
    assert min_clearance(WALL, box, np.array([[0.0, 0.0, 0.0, math.pi / 2]])) == pytest.approx(0.7)


def test_clearance_counts_moving_obstacles_where_they_were_at_the_time():
    walker = MovingObstacle("cylinder", ((0.0, 0.0, -3.0), (10.0, 0.0, 7.0)), radius=0.25)
    world = dataclasses.replace(WALL, moving=(walker,))
    round_body = robot_description("round", 0.3)
    # The walker walks up x = 0 at 1 m/s and crosses y = 0 at t = 3. At t = 3 the robot at (-2, 0) has it 2 m
    # ahead (2 - 0.3 - 0.25 = 1.45 m); at t = 0 the robot at (0, 0) has it 3 m away, but the wall 0.7 m.
    truth = np.array([[0.0, 0.0, 0.0, 0.0], [3.0, -2.0, 0.0, 0.0]])
    assert min_clearance(world, round_body, truth) == pytest.approx(0.7)
    truth = np.array([[3.0, -2.0, 0.0, 0.0]])
    assert min_clearance(world, round_body, truth) == pytest.approx(2.0 - 0.55)


def result(goal="library", success=True, clearance=0.4, **kw) -> GoalResult:
    values = dict(run=0, goal=goal, x=8.5, y=5.0, yaw=0.0, status="SUCCEEDED" if success else "ABORTED",
                  success=success, failures=[] if success else ["aborted: no plan"], reason="", time_s=31.5,
                  budget_s=80.0, path_length=12.6, straight_line=9.9, collisions=0, min_clearance=clearance,
                  replans=3, recoveries=0, cycle_p95_ms=41.2, cycles_missed=0, final=(8.5, 5.0, 0.0),
                  position_error=0.05, yaw_error=0.02, wall_s=20.0, max_vel_x=0.4, trajectory=[(0.0, 0.0, 0.0, 0.0), (31.5, 8.5, 5.0, 0.0)])
    values.update(kw)
    return GoalResult(**values)


def test_table_json_and_plot(tmp_path):
    results = [result(struck_standing=1, reference_length=12.0),
               result("lab", success=False, clearance=math.inf, time_s=10.0)]
    text = table(results)
    # 31.5 s for 12.6 m at 0.4 m/s: 1.0 would be top speed all the way; struck once while standing, still a success
    assert "library  SUCCEEDED   yes     31.5      80    12.6     9.9   1.27     1.00     0       1     0.40" in text
    assert "-> aborted: no plan" in text
    assert text.splitlines()[-1] == ("success 1/2 (50 %), mean time to goal 31.5 s sim (1.00 x path / max_vel_x), "
                                     "collisions while moving 0, struck while standing 1, min clearance 0.40 m, "
                                     # the challenge's score: OT 6 s (12 m at 2 m/s) / 31.5 s, and 0 for the failure
                                     "recoveries 0, BARN challenge score 0.095")
    write_json(tmp_path / "out.json", ScenarioOptions(), results)
    data = json.loads((tmp_path / "out.json").read_text())
    assert data["summary"]["success_rate"] == 0.5
    assert data["results"][1]["min_clearance"] is None
    assert data["options"]["world"] == "lab"
    plot(str(tmp_path / "out.png"), LAB, results, "lab")
    assert (tmp_path / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def run_cli(*args, timeout=600):
    env = dict(os.environ, PYTHONPATH=REPO)
    return subprocess.run([sys.executable, "-m", "simplebot_navigation.scenarios", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_bad_arguments_exit_2_with_the_option_named():
    proc = run_cli("--world", "lab", "--goals", "kitchen")
    assert proc.returncode == 2
    assert "error: lab.yaml: no goal named 'kitchen'" in proc.stderr
    proc = run_cli("--processes")
    assert proc.returncode == 2 and "--processes needs --rtf > 0" in proc.stderr
    proc = run_cli("--foxglove", "--foxglove-port", "70000")
    assert proc.returncode == 2 and "--foxglove-port must be 0..65535, got 70000" in proc.stderr


def test_the_command_drives_a_short_scenario_writes_json_and_png_and_serves_foxglove(tmp_path):
    proc = run_cli("--world", "empty", "--goals", "1.5,0,0", "--json", str(tmp_path / "r.json"),
                   "--plot", str(tmp_path / "r.png"), "--wall-timeout", "240", "--foxglove", "--foxglove-port", "0")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "Foxglove WebSocket server on ws://127.0.0.1:" in proc.stderr
    assert "[run 1/1 seed 0] goal 1/1 (1.5, 0): ok   SUCCEEDED" in proc.stdout
    data = json.loads((tmp_path / "r.json").read_text())
    (goal,) = data["results"]
    assert goal["success"] and goal["collisions"] == 0
    assert goal["path_length"] == pytest.approx(1.5, abs=0.25)
    assert (tmp_path / "r.png").stat().st_size > 10_000
