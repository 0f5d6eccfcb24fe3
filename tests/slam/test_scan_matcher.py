"""The correlative scan matcher on synthetic geometry: the robot's two lidars (683 beams, 5.6 m each) ray-cast
from a true pose in a non-symmetric L-shaped room with boxes and a cylinder, matched against the room's walls."""

import math

import numpy as np
import pytest

from simplebot_navigation.slam.scan_matcher import CorrelationGrid, ScanMatcher
from simplebot_navigation.slam.scan_points import ScanPoints, scan_points
from simplebot_navigation.testing.lidar_scenes import lidars, ray_ranges

RESOLUTION = 0.05


def _box(cx, cy, length, width, yaw=0.0):
    """The four sides (x0, y0, x1, y1) of a length x width box centred at (cx, cy), turned by yaw."""
    c, s = math.cos(yaw), math.sin(yaw)
    corners = [(cx + c * dx - s * dy, cy + s * dx + c * dy)
               for dx, dy in ((-length / 2, -width / 2), (length / 2, -width / 2), (length / 2, width / 2),
                              (-length / 2, width / 2))]
    return [(*corners[i], *corners[(i + 1) % 4]) for i in range(4)]


def _polygon(vertices):
    return [(*vertices[i], *vertices[(i + 1) % len(vertices)]) for i in range(len(vertices))]


#: an L-shaped room (8 x 7 m, the upper right 4 x 4 m cut away), two boxes (one turned) and a cylinder
ROOM = np.array(_polygon([(0, 0), (8, 0), (8, 3), (4, 3), (4, 7), (0, 7)]) + _box(5.9, 1.3, 0.8, 0.6)
                + _box(1.5, 5.0, 0.8, 0.5, 0.45) + _box(0.75, 2.9, 0.5, 0.8), dtype=float)
CYLINDERS = np.array([[2.6, 1.4, 0.25]])
#: a straight corridor 2 m wide and 40 m long along 30 degrees: its ends are far beyond the lidars' 5.6 m
CORRIDOR_AXIS = math.radians(30.0)
CORRIDOR = np.array([(-20 * math.cos(CORRIDOR_AXIS) - side * math.sin(CORRIDOR_AXIS),
                      -20 * math.sin(CORRIDOR_AXIS) + side * math.cos(CORRIDOR_AXIS),
                      20 * math.cos(CORRIDOR_AXIS) - side * math.sin(CORRIDOR_AXIS),
                      20 * math.sin(CORRIDOR_AXIS) + side * math.cos(CORRIDOR_AXIS)) for side in (-1.0, 1.0)])
TRUTH = (2.2, 2.3, 0.4)


def scan(pose, segments=ROOM, circles=CYLINDERS) -> np.ndarray:
    """The returns (base frame) of both lidars ray-cast from ``pose``, as SLAM gets them (ScanPoints.returns)."""
    x, y, yaw = pose
    parts = []
    for (mx, my, myaw), params in lidars():
        origin = np.array([x + mx * math.cos(yaw) - my * math.sin(yaw), y + mx * math.sin(yaw) + my * math.cos(yaw)])
        increment = (params.angle_max - params.angle_min) / (params.samples - 1)
        angles = yaw + myaw + params.angle_min + increment * np.arange(params.samples)
        ranges = ray_ranges(origin, angles, circles.reshape(-1, 3), segments)
        parts.append(scan_points(ranges, params.angle_min, increment, params.range_min, params.range_max,
                                 (mx, my, myaw), params.range_max))
    return ScanPoints.merged(parts).returns


def wall_points(segments=ROOM, circles=CYLINDERS, spacing=0.01) -> np.ndarray:
    """The walls sampled every ``spacing`` metres: the map's points."""
    points = []
    for x0, y0, x1, y1 in segments:
        t = np.linspace(0.0, 1.0, int(math.hypot(x1 - x0, y1 - y0) / spacing) + 2)
        points.append(np.column_stack((x0 + t * (x1 - x0), y0 + t * (y1 - y0))))
    for cx, cy, r in circles.reshape(-1, 3):
        a = np.linspace(0.0, 2 * math.pi, int(2 * math.pi * r / spacing) + 1, endpoint=False)
        points.append(np.column_stack((cx + r * np.cos(a), cy + r * np.sin(a))))
    return np.concatenate(points)


def occupancy(points, origin) -> np.ndarray:
    """The points rasterised into an int8 occupancy grid (100 on a point's cell, 0 elsewhere) from ``origin``."""
    cells = np.floor((points - origin) / RESOLUTION).astype(int)
    data = np.zeros(tuple(cells.max(axis=0)[::-1] + 40), np.int8)
    data[cells[:, 1], cells[:, 0]] = 100
    return data


def _errors(pose, truth):
    return math.dist(pose[:2], truth[:2]), abs(math.remainder(pose[2] - truth[2], 2 * math.pi))


@pytest.fixture(scope="module")
def room_grid():
    return CorrelationGrid.from_points(wall_points(), RESOLUTION)


@pytest.fixture(scope="module")
def room_scan():
    return scan(TRUTH)


@pytest.fixture(scope="module")
def occupancy_grid():
    """The room rasterised with cell centres on the whole metres, so its axis-aligned walls lie on cell centres:
    quantisation by a rasteriser that put them on cell borders would shift them by up to half a cell."""
    origin = np.array([-1.025, -1.025])
    return CorrelationGrid.from_occupancy(occupancy(wall_points(), origin), RESOLUTION, (*origin, 0.0))


@pytest.mark.parametrize("offset", [(0.31, -0.22, 0.15), (-0.37, 0.13, -0.3)])
@pytest.mark.parametrize("kind", ["points", "occupancy"])
def test_a_prior_off_by_decimetres_and_radians_is_pulled_back_to_the_truth(kind, offset, request, room_scan):
    grid = request.getfixturevalue(f"{kind}_grid" if kind == "occupancy" else "room_grid")
    prior = tuple(t + o for t, o in zip(TRUTH, offset))
    match = ScanMatcher().match(grid, room_scan, prior)
    distance, turn = _errors(match.pose, TRUTH)
    # 0.02 m is under half a cell, all a search on the 0.05 m lattice could promise; 0.01 rad moves the farthest
    # return (5.6 m) by one cell. The scene is noiseless, so only the matcher's own error is left.
    assert distance < 0.02 and turn < 0.01, (match.pose, TRUTH)


def test_the_refinement_lands_between_the_cells(room_grid, room_scan):
    """A prior off by half a cell in x and y: every pose of the search's lattice is >= 0.025 m off per axis."""
    prior = (TRUTH[0] + 0.325, TRUTH[1] - 0.225, TRUTH[2] + 0.1)
    lattice = ScanMatcher(refine=False).match(room_grid, room_scan, prior)
    refined = ScanMatcher().match(room_grid, room_scan, prior)
    assert _errors(lattice.pose, TRUTH)[0] > 0.025
    assert _errors(refined.pose, TRUTH)[0] < 0.01     # a fifth of a cell: the bicubic field is smooth at 2 cells' smear
    assert refined.response >= lattice.response


def test_the_response_is_near_one_at_the_truth_and_low_for_a_scan_of_another_place(room_grid, room_scan):
    at_truth = ScanMatcher().match(room_grid, room_scan, TRUTH)
    assert at_truth.response > 0.95                  # every return within millimetres of a wall
    elsewhere = ScanMatcher().match(room_grid, scan((1.0, 5.8, -1.2)), TRUTH)
    assert elsewhere.response < 0.5                  # ~0.3: only stray returns happen to meet a wall


def test_the_match_never_leaves_the_search_window(room_grid, room_scan):
    """The truth lies 0.8 m and 0.5 rad outside the window: the answer stays on its edge, not beyond."""
    prior = (TRUTH[0] + 0.8, TRUTH[1], TRUTH[2] + 0.5)
    match = ScanMatcher(0.4, 0.2).match(room_grid, room_scan, prior)
    assert abs(match.pose[0] - prior[0]) <= 0.4 + 1e-9 and abs(match.pose[1] - prior[1]) <= 0.4 + 1e-9
    assert abs(math.remainder(match.pose[2] - prior[2], 2 * math.pi)) <= 0.2 + 1e-9


def test_the_covariance_is_long_along_a_corridor_and_thin_across_it():
    grid = CorrelationGrid.from_points(wall_points(CORRIDOR, np.zeros((0, 3))), RESOLUTION)
    truth = (0.0, 0.0, CORRIDOR_AXIS + 0.1)
    match = ScanMatcher().match(grid, scan(truth, CORRIDOR, np.zeros((0, 3))), (0.1, -0.05, truth[2] + 0.05))
    covariance = match.covariance
    assert covariance.shape == (3, 3)
    np.testing.assert_allclose(covariance, covariance.T, rtol=0, atol=1e-15)
    assert (np.linalg.eigvalsh(covariance) > 0).all()
    values, vectors = np.linalg.eigh(covariance[:2, :2])
    major = math.atan2(vectors[1, 1], vectors[0, 1])
    assert abs(math.remainder(major - CORRIDOR_AXIS, math.pi)) < math.radians(5)
    # the walls fix the pose across to a few centimetres; along, the whole 1 m window fits as well
    assert values[1] > 10 * values[0]
    assert abs(match.pose[1] * math.cos(CORRIDOR_AXIS) - match.pose[0] * math.sin(CORRIDOR_AXIS)) < 0.02


def test_global_candidates_find_the_truth_without_a_prior(room_grid, room_scan):
    candidates = ScanMatcher().global_candidates(room_grid, room_scan, 3)
    assert len(candidates) == 3
    assert any(_errors(c.pose, TRUTH)[0] < 0.05 and _errors(c.pose, TRUTH)[1] < 0.02 for c in candidates)
    responses = [c.response for c in candidates]
    assert responses == sorted(responses, reverse=True)
    for i, a in enumerate(candidates):
        for b in candidates[:i]:
            distance, turn = _errors(a.pose, b.pose)
            assert distance >= 0.5 or turn >= 0.5


def test_global_candidates_stand_only_on_allowed_cells(room_grid, room_scan):
    rows, cols = room_grid.data.shape
    xs = room_grid.origin[0] + (np.arange(cols) + 0.5) * room_grid.resolution
    allowed = np.broadcast_to(xs > 4.5, (rows, cols)).copy()       # only the room's right arm
    candidates = ScanMatcher().global_candidates(room_grid, room_scan, 5, allowed)
    assert candidates and all(c.pose[0] > 4.5 - room_grid.resolution for c in candidates)
    assert all(c.response < 0.9 for c in candidates)              # the scan was taken in the left arm


def test_an_occupancy_field_is_one_on_walls_and_a_gaussian_of_the_distance_around_them():
    data = np.full((21, 21), -1, np.int8)
    data[10, 10] = 100
    data[0, :] = 40                                    # below the threshold: free
    grid = CorrelationGrid.from_occupancy(data, 0.05, (2.0, -1.0, 0.0), smear_deviation=0.1)
    assert grid.origin == (2.0, -1.0) and grid.data.shape == (21, 21)
    assert grid.data[10, 10] == 1.0
    assert grid.data[10, 12] == pytest.approx(math.exp(-0.5), rel=1e-5)        # 0.1 m, one deviation
    assert grid.data[14, 14] == pytest.approx(math.exp(-(0.2 ** 2 * 2) / 0.02), rel=1e-5)
    assert grid.data[0, 0] == 0.0                                               # beyond the smear


def _returns_with(value):
    points = scan(TRUTH)
    points[5] = value
    return points


@pytest.mark.parametrize("call, name", [
    (lambda g: ScanMatcher().match(g, _returns_with(np.nan), TRUTH), "points"),
    (lambda g: ScanMatcher().match(g, np.zeros((0, 2)), TRUTH), "points"),
    (lambda g: ScanMatcher().match(g, np.zeros((10, 3)), TRUTH), "points"),
    (lambda g: ScanMatcher().match(g, scan(TRUTH), (np.nan, 0.0, 0.0)), "prior"),
    (lambda g: ScanMatcher().match(g, scan(TRUTH), (1.0, 2.0)), "prior"),
    (lambda g: ScanMatcher().match(np.zeros((10, 10)), scan(TRUTH), TRUTH), "grid"),
    (lambda g: ScanMatcher(search_half_width=-0.1), "search_half_width"),
    (lambda g: ScanMatcher(search_half_angle=math.inf), "search_half_angle"),
    (lambda g: ScanMatcher(angle_resolution=-0.01), "angle_resolution"),
    (lambda g: ScanMatcher(search_half_width=100.0).match(g, scan(TRUTH), TRUTH), "search_half_width"),
    (lambda g: ScanMatcher(angle_resolution=1e-5).match(g, scan(TRUTH), TRUTH), "angle_resolution"),
    (lambda g: ScanMatcher().global_candidates(g, scan(TRUTH), 0), "count"),
    (lambda g: ScanMatcher().global_candidates(g, scan(TRUTH), 1000), "count"),
    (lambda g: ScanMatcher().global_candidates(g, scan(TRUTH), 3, np.ones((5, 5), bool)), "allowed"),
    (lambda g: CorrelationGrid.from_points(np.array([[0.0, np.nan]])), "points"),
    (lambda g: CorrelationGrid.from_points(np.zeros((0, 2))), "points"),
    (lambda g: CorrelationGrid.from_points(np.array([[0.0, 0.0], [1e4, 1e4]])), "points"),
    (lambda g: CorrelationGrid.from_points(wall_points(), smear_deviation=0.0), "smear_deviation"),
    (lambda g: CorrelationGrid.from_points(wall_points(), resolution=np.nan), "resolution"),
    (lambda g: CorrelationGrid.from_occupancy(np.zeros((5, 5), np.int8), 0.05, (0.0, 0.0, 0.3)), "origin"),
    (lambda g: CorrelationGrid.from_occupancy(np.zeros((5, 5), np.int8), 0.05, (0.0, np.inf, 0.0)), "origin"),
    (lambda g: CorrelationGrid.from_occupancy(np.zeros(5, np.int8), 0.05, (0.0, 0.0, 0.0)), "data"),
    (lambda g: CorrelationGrid.from_occupancy(np.zeros((5, 5), np.int8), 0.05, (0, 0, 0), occupied_threshold=0),
     "occupied_threshold"),
])
def test_hostile_input_is_refused_naming_the_argument(call, name, room_grid):
    with pytest.raises(ValueError, match=rf"^{name}:"):
        call(room_grid)
