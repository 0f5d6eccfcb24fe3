"""OrientationFilter modes on hand-made paths (docs/reference.md §3.4)."""

import math

import numpy as np
import pytest

from simplebot_navigation.planning import OrientationMode as M
from simplebot_navigation.planning.orientation import orient_path

# Along +x for 4 points, then a right angle up +y for 4 points; the last point is the goal.
L_PATH = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [3, 2], [3, 3], [3, 4]], float)


def test_forward_uses_the_position_derivative_and_keeps_the_goal_yaw():
    yaw = orient_path(L_PATH, 0.5, -1.0, M.FORWARD, 1)
    assert yaw[:3] == pytest.approx([0, 0, 0])
    assert yaw[3] == pytest.approx(math.atan2(1, 1))  # from point 2 to point 4
    assert yaw[4:7] == pytest.approx([math.pi / 2] * 3)
    assert yaw[7] == -1.0


def test_window_size_widens_the_derivative():
    yaw = orient_path(L_PATH, 0.0, 0.0, M.FORWARD, 2)
    assert yaw[2] == pytest.approx(math.atan2(1, 3))  # point 0 to point 4


@pytest.mark.parametrize("mode, offset", [(M.BACKWARD, math.pi), (M.LEFTWARD, -math.pi / 2),
                                          (M.RIGHTWARD, math.pi / 2)])
def test_backward_leftward_rightward_offsets(mode, offset):
    forward = orient_path(L_PATH, 0.0, 0.2, M.FORWARD, 1)
    yaw = orient_path(L_PATH, 0.0, 0.2, mode, 1)
    assert np.allclose(np.exp(1j * yaw[:-1]), np.exp(1j * (forward[:-1] + offset)))
    assert yaw[-1] == 0.2


def test_none_leaves_zero_yaw_except_the_goal():
    assert orient_path(L_PATH, 1.0, 2.0, M.NONE, 1).tolist() == [0.0] * 7 + [2.0]


def test_interpolate_blends_linearly_the_short_way_round():
    yaw = orient_path(L_PATH, 3.0, -3.0, M.INTERPOLATE, 1)
    step = (2 * math.pi - 6.0) / 7  # from 3.0 to -3.0 through pi
    expected = np.angle(np.exp(1j * (3.0 + step * np.arange(8))))
    assert np.allclose(np.exp(1j * yaw), np.exp(1j * expected))
    assert yaw[-1] == pytest.approx(-3.0)


def test_forward_then_interpolate_blends_only_the_last_straight_section():
    yaw = orient_path(L_PATH, 0.4, 0.0, M.FORWARD_THEN_INTERPOLATE, 1)
    assert yaw[0] == 0.4  # ROS sets the first pose to the start yaw
    assert yaw[1:3] == pytest.approx([0, 0])
    # Last straight section starts at point 4 (heading pi/2) and blends to the goal yaw 0.
    assert yaw[4:] == pytest.approx(np.linspace(math.pi / 2, 0.0, 4))


def test_short_paths():
    assert orient_path(np.zeros((0, 2)), 0, 0, M.FORWARD, 1).shape == (0,)
    assert orient_path(np.array([[1.0, 2.0]]), 0.3, 0.7, M.INTERPOLATE, 1).tolist() == [0.7]
    two = orient_path(np.array([[0.0, 0.0], [1.0, 1.0]]), 0.3, 0.7,
                      M.FORWARD_THEN_INTERPOLATE, 1)
    assert two == pytest.approx([0.3, 0.7])
