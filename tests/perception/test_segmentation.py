"""Segmentation of one scan: clusters, their centres and radii, occluded ends, hostile ranges."""

import numpy as np
import pytest

from simplebot_navigation.perception import Scan, TrackerParams, segment
from simplebot_navigation.testing.lidar_scenes import Cylinder, ray_ranges, scans_at

P = TrackerParams()


def clusters_of(scan):
    return segment(scan, P.breakpoint_angle, P.breakpoint_distance, P.range_noise, P.min_points)


@pytest.mark.parametrize("distance", [1.0, 2.5, 4.5])
@pytest.mark.parametrize("radius", [0.15, 0.3])
def test_a_cylinder_gives_its_centre_and_radius(distance, radius):
    front = scans_at((0.0, 0.0, 0.0), 0.0, [Cylinder(radius, (distance, 0.7))], noise=0.0)[0]
    clusters = clusters_of(front)
    assert len(clusters) == 1
    assert np.hypot(*(clusters.centre[0] - (distance, 0.7))) < 0.03
    assert abs(clusters.radius[0] - radius) < 0.04
    assert not clusters.occluded[0]


def test_a_wall_behind_a_cylinder_is_cut_in_two_occluded_pieces():
    front = scans_at((0.0, 0.0, 0.0), 0.0, [Cylinder(0.25, (1.5, 0.0))], [(3.0, -2.0, 3.0, 2.0)], noise=0.0)[0]
    clusters = clusters_of(front)
    assert len(clusters) == 3
    person = int(np.argmin(np.hypot(*(clusters.centre - (1.5, 0.0)).T)))
    assert not clusters.occluded[person]
    assert clusters.occluded[np.arange(3) != person].all()
    assert (clusters.width[np.arange(3) != person] > 1.0).all()


def test_no_return_beams_between_two_obstacles_separate_them():
    front = scans_at((0.0, 0.0, 0.0), 0.0, [Cylinder(0.2, (3.0, 0.3)), Cylinder(0.2, (3.0, -0.3))], noise=0.0)[0]
    assert len(clusters_of(front)) == 2


def test_hostile_ranges_give_no_clusters_and_no_error():
    n = 683
    angles = np.linspace(-2.0, 2.0, n)
    for ranges in (np.full(n, np.nan), np.full(n, -1.0), np.full(n, np.inf), np.zeros(0)):
        scan = Scan(np.zeros(2), angles[:len(ranges)], ranges, 0.2, 5.6)
        assert len(clusters_of(scan)) == 0
    mixed = np.where(np.arange(n) % 2, np.nan, 2.0)       # every other beam lost: still one surface
    assert len(clusters_of(Scan(np.zeros(2), angles, mixed, 0.2, 5.6))) >= 1


ANGLES = np.radians(np.arange(-120.0, 120.0, 0.352))


def _scan(circles=(), segments=(), noise=0.01, seed=0):
    ranges = ray_ranges(np.zeros(2), ANGLES, np.array(circles, dtype=float).reshape(-1, 3),
                        np.array(segments, dtype=float).reshape(-1, 4))
    ranges = ranges + np.random.default_rng(seed).normal(0.0, noise, len(ranges))
    return Scan(np.zeros(2), ANGLES, ranges, 0.2, 5.6)


def test_a_wall_seen_at_a_grazing_angle_breaks_into_pieces_that_are_no_outlines():
    """A wall 0.3 m beside the sensor, along its heading, breaks up where the beams graze it; every piece short
    enough to be tracked is joined to the next along the line, or cut by the range limit: unfit (structure)."""
    pieces = []
    for seed in range(6):
        clusters = clusters_of(_scan(segments=[(0.0, 0.3, 8.0, 0.3)], seed=seed))
        pieces += list(clusters.unfit[clusters.width <= P.max_obstacle_size])
    assert len(pieces) >= 2 and all(pieces)


@pytest.mark.parametrize("seed", range(3))
def test_people_one_behind_the_other_are_two_outlines_not_a_surface(seed):
    """Their outlines meet at an angle, the farther one's end within 0.25 m of the nearer one's."""
    clusters = clusters_of(_scan(circles=[(2.0, 0.2, 0.25), (2.3, -0.25, 0.25)], seed=seed))
    assert len(clusters) == 2 and clusters.occluded.any()
    assert not clusters.unfit.any()


def test_an_arc_cut_by_the_range_limit_is_an_outline_and_a_straight_piece_is_not():
    arc = clusters_of(_scan(circles=[(5.6, 0.0, 0.35)]))
    assert len(arc) == 1 and arc.occluded[0] and not arc.unfit[0]
    wall = clusters_of(_scan(segments=[(5.2, -0.3, 6.2, 0.3)]))
    assert len(wall) == 1 and wall.unfit[0]
    assert arc.range_cut[0]


def test_an_arc_cut_by_something_nearer_is_not_cut_by_the_range_limit():
    """A person half hidden behind another: its cut slides across the line of sight as the sensor moves."""
    clusters = clusters_of(_scan(circles=[(1.5, 0.15, 0.25), (2.5, -0.2, 0.25)]))
    behind = int(np.argmax(np.hypot(*clusters.centre.T)))
    assert clusters.occluded[behind] and not clusters.range_cut[behind]


@pytest.mark.parametrize("seed", range(3))
def test_a_whole_piece_of_wall_seen_at_a_grazing_angle_is_no_outline(seed):
    """A free-standing board 1.2 m long, 20 degrees off the line of sight: its returns span 1.2 m in range and 9
    degrees in bearing, as if of a thing 0.15 m in radius. Taken for a round thing its centre slides as the sensor
    moves, so it is unfit; a round outline's returns lie within its radius in range."""
    clusters = clusters_of(_scan(segments=[(1.5, 0.3, 2.525, 0.923)], seed=seed))
    assert len(clusters) == 1 and not clusters.occluded[0] and clusters.unfit[0]
    person = clusters_of(_scan(circles=[(2.0, 0.3, 0.25)], seed=seed))
    assert len(person) == 1 and not person.unfit[0]
