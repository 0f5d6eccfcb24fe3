import math

import numpy as np
import pytest

from simplebot_navigation.teb.footprint import FootprintModel

from .scenes import LAB_FOOTPRINT, LAB_TWO_CIRCLES

TWO = FootprintModel.from_params(LAB_TWO_CIRCLES)
CIRCLE = FootprintModel.circular(0.4)


def test_two_circles_against_circular_exact_distances():
    pose = np.array([[0.0, 0.0, 0.0]])
    obstacles = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.5, 0.5]])
    # front centre (0.2, 0), rear centre (-0.2, 0), radii 0.2
    expected_two = [0.8 - 0.2, 0.8 - 0.2, math.hypot(0.2, 1.0) - 0.2, math.hypot(0.3, 0.5) - 0.2]
    expected_circle = [0.6, 0.6, 0.6, math.hypot(0.5, 0.5) - 0.4]
    np.testing.assert_allclose(TWO.distances(pose, obstacles)[0], expected_two, atol=1e-12)
    np.testing.assert_allclose(CIRCLE.distances(pose, obstacles)[0], expected_circle, atol=1e-12)


def test_two_circles_turn_with_the_robot():
    # heading +90 deg: the front circle sits at (1, 2.2) for a robot at (1, 2)
    pose = np.array([[1.0, 2.0, math.pi / 2]])
    d = TWO.distances(pose, np.array([[1.0, 3.0], [2.0, 2.0]]))[0]
    np.testing.assert_allclose(d, [0.8 - 0.2, math.hypot(1.0, 0.2) - 0.2], atol=1e-12)


def test_point_line_polygon_distances():
    pose = np.array([[0.0, 0.0, 0.0]])
    obstacles = np.array([[1.0, 0.0], [1.0, 1.0], [0.1, 0.0], [0.0, 0.5]])
    point = FootprintModel.from_params({"type": "point"})
    np.testing.assert_allclose(point.distances(pose, obstacles)[0],
                               [1.0, math.sqrt(2.0), 0.1, 0.5], atol=1e-12)
    line = FootprintModel.from_params({"type": "line", "line_start": [-0.3, 0.0], "line_end": [0.3, 0.0]})
    np.testing.assert_allclose(line.distances(pose, obstacles)[0],
                               [0.7, math.hypot(0.7, 1.0), 0.0, 0.5], atol=1e-12)
    poly = FootprintModel.from_params({"type": "polygon", "vertices": LAB_FOOTPRINT.tolist()})
    # inside the polygon the distance is negative: depth to the nearest edge
    np.testing.assert_allclose(poly.distances(pose, obstacles)[0],
                               [0.55, math.hypot(0.55, 0.7), -0.3, 0.2], atol=1e-12)
    # a nested list reaches a ROS 2 node as a string: the same polygon
    as_ros2_parameter = FootprintModel.from_params({"type": "polygon", "vertices": str(LAB_FOOTPRINT.tolist())})
    np.testing.assert_allclose(as_ros2_parameter.distances(pose, obstacles), poly.distances(pose, obstacles))


def test_inscribed_radii():
    assert TWO.inscribed_radius == pytest.approx(0.2)
    uneven = FootprintModel.two_circles(0.3, 0.25, 0.1, 0.15)
    assert uneven.inscribed_radius == pytest.approx(0.15)          # min(min(0.25, 0.55), min(0.15, 0.25))
    assert FootprintModel.two_circles(0.0, 0.3, 0.0, 0.4).inscribed_radius == pytest.approx(0.3)
    assert CIRCLE.inscribed_radius == 0.4
    assert FootprintModel.polygon(LAB_FOOTPRINT).inscribed_radius == pytest.approx(0.3)
    assert FootprintModel.point().inscribed_radius == 0.0
    assert FootprintModel.line([-0.3, 0], [0.3, 0]).inscribed_radius == 0.0


@pytest.mark.parametrize("params", [
    None, {}, {"type": "triangle"}, {"type": "two_circles", "front_offset": 0.2},
    {"type": "circular"}, {"type": "polygon"}, {"type": "line", "line_start": [0, 0]},
])
def test_missing_or_invalid_model_falls_back_to_point_with_a_warning(params):
    model = FootprintModel.from_params(params)
    assert model.kind == "point"
    assert model.warnings and "point" in model.warnings[0]


@pytest.mark.parametrize("params, name", [
    ({"type": "circular", "radius": "big"}, "radius"),
    ({"type": "circular", "radius": float("nan")}, "radius"),
    ({"type": "line", "line_start": [0, float("inf")], "line_end": [1, 0]}, r"line_start\[1\]"),
    ({"type": "line", "line_start": [0, 0], "line_end": [1]}, "line_end"),
    ({"type": "polygon", "vertices": [[0, 0], [1, 0]]}, "vertices"),
    ({"type": "polygon", "vertices": "[[0, 0], [1, 0], [1"}, "vertices"),
    ({**LAB_TWO_CIRCLES, "rear_radius": None}, "rear_radius"),
])
def test_malformed_values_raise_naming_the_parameter(params, name):
    with pytest.raises(ValueError, match=name):
        FootprintModel.from_params(params)


@pytest.mark.parametrize("model", [
    TWO, CIRCLE, FootprintModel.point(), FootprintModel.line([-0.3, 0.1], [0.4, -0.1]),
    FootprintModel.polygon(LAB_FOOTPRINT),
], ids=lambda m: m.kind)
def test_pose_gradient_matches_finite_differences(model):
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-1, 1, 40), rng.uniform(-1, 1, 40), rng.uniform(-3, 3, 40)])
    points = rng.uniform(-2, 2, (40, 2))
    d, grad = model.distance_and_gradient(poses, points)
    np.testing.assert_allclose(d, model.pair_distances(poses, points), atol=1e-12)
    np.testing.assert_allclose(d, np.diag(model.distances(poses, points)), atol=1e-12)
    h = 1e-6
    for k in range(3):
        step = np.zeros(3)
        step[k] = h
        numeric = (model.pair_distances(poses + step, points) - model.pair_distances(poses - step, points)) / (2 * h)
        np.testing.assert_allclose(grad[:, k], numeric, atol=1e-6)


def test_outline_follows_the_pose_with_one_ring_per_circle():
    front, rear = TWO.outline(np.array([[1.0, 2.0, math.pi / 2]]), circle_points=4)[0]
    # front circle centre (1, 2.2): its first sample is at angle 0 in the robot frame -> +y in the world
    np.testing.assert_allclose(front[0], [1.0, 2.4], atol=1e-12)
    np.testing.assert_allclose(front[0], front[-1], atol=1e-12)     # each ring closes on itself
    np.testing.assert_allclose(rear.mean(axis=0), [1.0, 1.8], atol=0.1)
