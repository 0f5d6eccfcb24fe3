"""BackUpRecovery, SpinRecovery and the trail they back up along, driven as move_base steps them."""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.move_base.recovery import PoseTrail
from simplebot_navigation.move_base.recovery.backup import BackUpRecovery
from simplebot_navigation.move_base.recovery.spin import SpinRecovery, free_area_left_right

DT = 0.05


def drive(recovery, pose, seconds=30.0):
    """Step a recovery on an ideal diff-drive robot; returns the final pose, the last step and the poses."""
    t, poses = 0.0, [pose]
    recovery.start(t, pose)
    for _ in range(int(seconds / DT)):
        step = recovery.tick(t, pose)
        if step.done:
            return pose, step, np.array(poses)
        v, omega = step.cmd
        x, y, yaw = pose
        pose = (x + v * DT * math.cos(yaw), y + v * DT * math.sin(yaw), math.remainder(yaw + omega * DT, 2 * math.pi))
        poses.append(pose)
        t += DT
    raise AssertionError("the recovery never finished")


def test_the_trail_keeps_a_point_every_spacing_and_cuts_loops():
    trail = PoseTrail(spacing=0.05)
    for x in np.arange(0.0, 1.001, 0.01):
        trail.record(x, 0.0)
    gaps = np.diff(trail.back_from(1.0, 0.0, 10.0)[::-1, 0])
    assert len(trail) >= 17 and (gaps >= 0.05 - 1e-9).all() and (gaps < 0.07).all()
    for x in np.arange(1.0, 0.49, -0.01):      # back the way it came: the trail shrinks with it
        trail.record(x, 0.0)
    back = trail.back_from(0.5, 0.0, 10.0)
    assert 0.42 < back[0, 0] <= 0.5 and back[-1, 0] == 0.0
    size = len(trail)
    trail.record(float("nan"), 0.0)
    assert len(trail) == size


def test_the_trail_backwards_stops_at_the_distance_asked():
    trail = PoseTrail(spacing=0.05)
    for x in np.arange(0.0, 2.001, 0.01):
        trail.record(x, 0.0)
    back = trail.back_from(2.0, 0.0, 0.5)
    assert back[0, 0] > 1.9 and back[-1, 0] == pytest.approx(1.5, abs=0.06) and (np.diff(back[:, 0]) < 0).all()


def test_back_up_reverses_along_the_arc_the_robot_came_by():
    trail = PoseTrail()
    radius = 1.0
    for a in np.linspace(0.0, 1.2, 200):      # drove forward on a left turn of radius 1 m around (0, 1)
        trail.record(radius * math.sin(a), radius * (1.0 - math.cos(a)))
    start = (radius * math.sin(1.2), radius * (1.0 - math.cos(1.2)), 1.2)
    backup = BackUpRecovery("back_up", {"backup_dist": 0.6}, lambda p: np.ones(len(p), bool), trail)
    end, step, driven = drive(backup, start)
    assert step.message.startswith("back_up: backed up 0.") and float(step.message.split()[3]) >= 0.58
    off_arc = np.abs(np.hypot(driven[:, 0], driven[:, 1] - radius) - radius)
    assert off_arc.max() < 0.03                      # it stayed on the known-free arc
    assert math.hypot(end[0] - start[0], end[1] - start[1]) == pytest.approx(0.59, abs=0.03)


def test_back_up_without_a_trail_goes_straight_back():
    backup = BackUpRecovery("back_up", {}, lambda p: np.ones(len(p), bool), PoseTrail())
    end, step, _ = drive(backup, (1.0, 2.0, math.pi / 2))
    assert end[0] == pytest.approx(1.0, abs=1e-6) and end[1] == pytest.approx(1.7, abs=0.02)
    assert step.cmd == (0.0, 0.0)


def test_back_up_stops_short_of_an_obstacle_behind():
    backup = BackUpRecovery("back_up", {"backup_dist": 1.0}, lambda p: p[:, 0] > -0.2, PoseTrail())
    end, step, driven = drive(backup, (0.0, 0.0, 0.0))
    assert "a collision lies behind the robot" in step.message
    assert -0.2 < driven[:, 0].min() < -0.12           # as far as it could without touching


def test_spin_turns_towards_the_freer_side():
    spin = SpinRecovery("spin", {}, lambda p: np.ones(len(p), bool), lambda pose: (1.0, 3.0))
    end, step, _ = drive(spin, (0.0, 0.0, 0.0))
    assert end[2] == pytest.approx(-math.pi / 2, abs=0.05)
    assert "to the right" in step.message


def test_spin_turns_the_other_way_when_the_freer_side_is_blocked_soon():
    blocked_right = lambda p: p[:, 2] > -0.3        # noqa: E731 - the footprint hits something 0.3 rad to the right
    spin = SpinRecovery("spin", {}, blocked_right, lambda pose: (1.0, 3.0))
    end, step, _ = drive(spin, (0.0, 0.0, 0.0))
    assert end[2] == pytest.approx(math.pi / 2, abs=0.05)


def test_spin_turns_as_far_as_the_footprint_allows():
    spin = SpinRecovery("spin", {}, lambda p: np.abs(p[:, 2]) < 0.8, lambda pose: (2.0, 1.0))
    end, step, driven = drive(spin, (0.0, 0.0, 0.0))
    assert 0.7 < end[2] < 0.8 and np.abs(driven[:, 2]).max() < 0.8


def test_spin_refuses_when_neither_way_is_free():
    spin = SpinRecovery("spin", {}, lambda p: np.zeros(len(p), bool), lambda pose: (2.0, 1.0))
    end, step, _ = drive(spin, (0.0, 0.0, 0.0))
    assert end == (0.0, 0.0, 0.0) and "can't turn in place either way" in step.message


def test_free_area_counts_the_free_cells_on_each_side():
    costmap = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    costmap.costmap[60:, :] = LETHAL_OBSTACLE            # y > 0.5: a wall on the left of a robot facing +x
    left, right = free_area_left_right(costmap, (0.0, 0.0, 0.0), 1.0)
    assert right == pytest.approx(math.pi / 2, rel=0.1)
    assert left == pytest.approx(math.pi / 2 - (math.acos(0.5) - 0.5 * math.sqrt(0.75)), rel=0.1)
    assert free_area_left_right(costmap, (0.0, 0.0, math.pi), 1.0)[1] == pytest.approx(left)
