"""simplebot_navigation.geometry: the conventions every layer relies on."""

import math

import numpy as np
import pytest

from simplebot_navigation import geometry as g


@pytest.mark.parametrize("theta, wrapped", [(0.0, 0.0), (math.pi / 2, math.pi / 2), (3 * math.pi / 2, -math.pi / 2),
                                            (-3 * math.pi / 2, math.pi / 2), (math.pi, -math.pi),
                                            (7 * math.pi + 0.1, -math.pi + 0.1)])
def test_normalize_theta_wraps_into_minus_pi_to_pi(theta, wrapped):
    assert float(g.normalize_theta(theta)) == pytest.approx(wrapped)


def test_normalize_theta_works_elementwise():
    np.testing.assert_allclose(g.normalize_theta(np.array([0.0, 2 * math.pi + 0.5, -2 * math.pi - 0.5])),
                               [0.0, 0.5, -0.5], atol=1e-12)


@pytest.mark.parametrize("yaw", [0.0, 0.3, -1.2, math.pi - 1e-9, -math.pi + 1e-9, 2.9])
def test_yaw_survives_a_round_trip_through_a_quaternion(yaw):
    q = g.yaw_to_quaternion(yaw)
    assert sum(c * c for c in q) == pytest.approx(1.0)
    assert g.quaternion_to_yaw(*q) == pytest.approx(yaw)


def test_yaw_of_a_tilted_rotation_is_its_heading():
    q = g.rpy_to_quaternion((0.2, -0.1, 1.0))
    assert g.quaternion_to_yaw(*q) == pytest.approx(1.0)


def test_axis_angle_about_z_is_a_yaw():
    np.testing.assert_allclose(g.axis_angle_to_quaternion((0.0, 0.0, 1.0), 0.7), g.yaw_to_quaternion(0.7))


def test_rotation_matrix_matches_rotating_a_vector():
    q = g.rpy_to_quaternion((0.4, 0.3, -0.8))
    v = (0.5, -1.0, 2.0)
    np.testing.assert_allclose(g.quaternion_to_rotation_matrix(*q) @ v, g.rotate_vector(q, v), atol=1e-12)


def test_transform_points_places_points_and_poses():
    pose = (1.0, 2.0, math.pi / 2)
    np.testing.assert_allclose(g.transform_points(pose, np.array([[1.0, 0.0], [0.0, 1.0]])),
                               [[1.0, 3.0], [0.0, 2.0]], atol=1e-12)
    placed = g.transform_points(pose, np.array([[1.0, 0.0, 0.5]]))
    np.testing.assert_allclose(placed, [[1.0, 3.0, math.pi / 2 + 0.5]], atol=1e-12)
    assert g.transform_points(pose, np.zeros((2, 2)), dtype=np.float32).dtype == np.float32


def test_inverse_transform_points_undoes_transform_points():
    frame = (0.5, -1.0, 2.5)
    poses = np.array([[3.0, 1.0, -2.0], [-1.0, 0.25, 0.5]])
    np.testing.assert_allclose(g.transform_points(frame, g.inverse_transform_points(frame, poses)), poses,
                               atol=1e-12)
    np.testing.assert_allclose(g.inverse_transform_points(frame, poses[:, :2]),
                               g.inverse_transform_points(frame, poses)[:, :2], atol=0)
    frames = np.array([frame, (0.0, 0.0, 0.0)])
    both = g.inverse_transform_points(frames[:, None, :], poses[None, :, :2])
    assert both.shape == (2, 2, 2)
    np.testing.assert_allclose(both[1], poses[:, :2], atol=0)
    np.testing.assert_allclose(both[0], g.inverse_transform_points(frame, poses[:, :2]), atol=0)


def test_pose_in_frame_undoes_transform_points():
    frame = (0.5, -1.0, 2.5)
    pose = (3.0, 1.0, -2.0)
    local = g.pose_in_frame(frame, pose)
    back = g.transform_points(frame, np.array([local]))[0]
    np.testing.assert_allclose(back[:2], pose[:2], atol=1e-12)
    assert math.remainder(back[2] - pose[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
    assert -math.pi <= local[2] <= math.pi


def test_compose_with_the_inverse_is_the_identity():
    a = (1.0, -2.0, 0.5, *g.rpy_to_quaternion((0.1, 0.2, 0.3)))
    identity = g.compose(a, g.inverse(a))
    np.testing.assert_allclose(identity[:3], (0.0, 0.0, 0.0), atol=1e-12)
    assert abs(identity[6]) == pytest.approx(1.0)


def test_compose_applies_the_child_in_the_parent_frame():
    parent = (1.0, 0.0, 0.0, *g.yaw_to_quaternion(math.pi / 2))
    child = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    np.testing.assert_allclose(g.compose(parent, child)[:3], (1.0, 1.0, 0.0), atol=1e-12)


def test_interpolate_is_halfway_in_translation_and_rotation():
    a = (0.0, 0.0, 0.0, *g.yaw_to_quaternion(0.0))
    b = (2.0, 4.0, 0.0, *g.yaw_to_quaternion(1.0))
    mid = g.interpolate(a, b, 0.5)
    np.testing.assert_allclose(mid[:3], (1.0, 2.0, 0.0))
    assert g.quaternion_to_yaw(*mid[3:]) == pytest.approx(0.5)


def test_slerp_takes_the_short_way_round():
    q0 = g.yaw_to_quaternion(3.0)
    q1 = tuple(-c for c in g.yaw_to_quaternion(-3.0))    # same rotation as yaw -3, other sign
    assert abs(g.quaternion_to_yaw(*g.slerp(q0, q1, 0.5))) == pytest.approx(math.pi, abs=1e-9)
