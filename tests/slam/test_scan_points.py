"""A LaserScan as SLAM keeps it: returns, misses that only clear, and what tells nothing dropped."""

import math

import numpy as np
import pytest

from simplebot_navigation.slam.scan_points import MAX_BEAMS, ScanPoints, scan_points


def test_returns_misses_and_unusable_readings():
    ranges = [1.0, math.inf, math.nan, 0.05, 7.0, -math.inf, 2.0]
    scan = scan_points(ranges, -math.pi / 2, math.pi / 6, 0.1, 10.0, (0.2, 0.0, 0.0), max_laser_range=5.0)
    # nan, -inf and below range_min tell nothing; inf and beyond max_laser_range clear up to 5 m
    assert len(scan) == 4
    assert scan.hits.tolist() == [True, False, False, True]
    lengths = np.hypot(*(scan.ends - scan.origins).T)
    assert lengths == pytest.approx([1.0, 5.0, 5.0, 2.0])
    # beam 0 points at -90 deg from a sensor 0.2 m ahead of the base
    assert scan.ends[0] == pytest.approx([0.2, -1.0])
    assert scan.returns.shape == (2, 2)


def test_sensor_pose_and_frame_change():
    scan = scan_points([1.0], 0.0, 0.1, 0.0, 5.0, (-0.3, 0.0, math.pi), max_laser_range=5.0)
    assert scan.ends[0] == pytest.approx([-1.3, 0.0])      # a rear lidar looks backwards
    origins, ends = scan.in_frame((1.0, 2.0, math.pi / 2))
    assert ends[0] == pytest.approx([1.0, 0.7])
    assert origins[0] == pytest.approx([1.0, 1.7])


def test_merged_keeps_every_beam_with_its_own_sensor():
    front = scan_points([1.0, 2.0], 0.0, 0.1, 0.0, 5.0, (0.4, 0.0, 0.0), 5.0)
    back = scan_points([1.0], 0.0, 0.1, 0.0, 5.0, (-0.4, 0.0, math.pi), 5.0)
    merged = ScanPoints.merged([front, back])
    assert len(merged) == 3
    assert merged.origins[:, 0].tolist() == [0.4, 0.4, -0.4]


@pytest.mark.parametrize("kwargs, word", [
    ({"angle_increment": 0.0}, "angle_increment"),
    ({"angle_increment": math.nan}, "angle_increment"),
    ({"range_min": 6.0}, "range_min"),
    ({"sensor_pose": (0.0, math.inf, 0.0)}, "sensor_pose"),
    ({"ranges": []}, "ranges"),
    ({"ranges": np.ones(MAX_BEAMS + 1)}, "ranges"),
    ({"ranges": np.ones((2, 2))}, "ranges"),
    ({"angle_increment": 1.0}, "angle_increment"),      # 10 beams a radian apart: more than a turn
])
def test_hostile_scans_are_refused_with_the_field(kwargs, word):
    args = {"ranges": np.ones(10), "angle_min": 0.0, "angle_increment": 0.01, "range_min": 0.1, "range_max": 5.0,
            "sensor_pose": (0.0, 0.0, 0.0), "max_laser_range": 5.0, **kwargs}
    with pytest.raises(ValueError, match=word):
        scan_points(**args)


def test_surfaces_fill_in_between_neighbouring_returns_of_one_sensor_only():
    ends = np.array([[1.0, 0.0], [1.0, 0.1], [1.0, 0.3], [2.0, 0.3], [2.0, 0.35], [2.0, 0.4], [2.0, 0.5]])
    origins = np.zeros((7, 2))
    origins[6:] = (0.3, 0.0)                                    # the last beam is another lidar's
    hits = np.array([True, True, True, True, False, True, True])
    filled = ScanPoints(origins, ends, hits).surfaces(max_gap=0.25, spacing=0.05)
    assert np.allclose(filled[:6], ends[hits])                  # the returns first, as they were
    added = {tuple(np.round(p, 6)) for p in filled[6:]}
    # 0.1 m apart: one point between; 0.2 m apart: three; 1.0 m apart (a wall's edge and what lies behind it),
    # a miss in between, and two sensors' neighbouring beams: none
    assert added == {(1.0, 0.05), (1.0, 0.15), (1.0, 0.2), (1.0, 0.25)}
    assert len(filled) == 6 + 4


def test_a_scan_knows_its_sensors():
    origins = np.array([[0.3, 0.0], [0.3, 0.0], [-0.3, 0.0]])
    points = ScanPoints(origins, np.ones((3, 2)), np.ones(3, dtype=bool))
    assert points.sensors.tolist() == [[-0.3, 0.0], [0.3, 0.0]]
