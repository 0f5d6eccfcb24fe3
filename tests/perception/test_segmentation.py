"""Segmentation of one scan: clusters, their centres and radii, occluded ends, hostile ranges."""

import numpy as np
import pytest

from simplebot_navigation.perception import Scan, TrackerParams, segment
from simplebot_navigation.testing.lidar_scenes import Cylinder, scans_at

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
