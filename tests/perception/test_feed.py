"""The obstacle feed: sources merged and placed in the frame a user asks for (perception/feed.py)."""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.perception.feed import MovingObstacles, ObstacleFeed


class Source:
    """An ObstacleSource with one obstacle and one clearing circle, in `frame`."""

    def __init__(self, frame: str, row, covariance=None, circle=(0.0, 0.0, 0.5)):
        self.frame = frame
        self.row = np.asarray(row, dtype=float)
        self.covariance = np.diag([0.01, 0.04, 0.25, 0.0]) if covariance is None else covariance
        self.circle = np.asarray([circle], dtype=float)
        self.asked: list[float] = []

    def moving_obstacles(self, now: float) -> MovingObstacles:
        self.asked.append(now)
        return MovingObstacles(self.frame, now, self.row[None, :], self.covariance[None])

    def clearing_circles(self, now: float) -> np.ndarray:
        return self.circle


def placements(known: dict):
    return lambda target, source: known.get((target, source))


def test_a_source_in_another_frame_is_moved_and_turned_with_its_covariance():
    # map <- odom: odom's origin at (10, 0), turned a quarter left
    feed = ObstacleFeed(placements({("map", "odom"): (10.0, 0.0, math.pi / 2)}),
                        (Source("odom", [1.0, 0.0, 1.0, 0.0, 0.3]),))
    got = feed.moving_obstacles(4.0, "map")
    assert got.frame == "map" and got.stamp == 4.0 and len(got) == 1
    np.testing.assert_allclose(got.rows[0], [10.0, 1.0, 0.0, 1.0, 0.3], atol=1e-12)
    # x and y swap their variances, and so do vx and vy; a covariance stays symmetric
    np.testing.assert_allclose(np.diag(got.covariance[0]), [0.04, 0.01, 0.0, 0.25], atol=1e-12)
    np.testing.assert_allclose(got.covariance[0], got.covariance[0].T)
    np.testing.assert_allclose(feed.clearing_circles(4.0, "map"), [[10.0, 0.0, 0.5]], atol=1e-12)


def test_sources_are_merged_and_one_that_cannot_be_placed_is_skipped():
    here = Source("odom", [1.0, 2.0, 0.0, 0.0, 0.2])
    lost = Source("robot2/odom", [5.0, 5.0, 0.0, 0.0, 0.2])
    unknown_yet = Source("", [7.0, 7.0, 0.0, 0.0, 0.2])
    other = Source("map", [3.0, 0.0, -1.0, 0.0, 0.4])
    feed = ObstacleFeed(placements({("odom", "map"): (0.0, 0.0, 0.0)}), (here, lost, unknown_yet))
    feed.add(other)
    got = feed.moving_obstacles(1.5, "odom")
    np.testing.assert_allclose(got.rows[:, 0], [1.0, 3.0])
    assert got.covariance.shape == (2, 4, 4)
    assert not lost.asked and not unknown_yet.asked and here.asked == [1.5]
    assert len(feed.clearing_circles(1.5, "odom")) == 2


def test_no_source_gives_empty_arrays_of_the_right_shapes():
    feed = ObstacleFeed(placements({}))
    got = feed.moving_obstacles(0.0, "odom")
    assert got.rows.shape == (0, 5) and got.covariance.shape == (0, 4, 4)
    assert feed.clearing_circles(0.0, "odom").shape == (0, 3)
