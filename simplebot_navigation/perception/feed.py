"""One obstacle feed: every moving obstacle move_base knows of, with its uncertainty, and where the costmaps should
clear after them, at a time and in a frame (docs/reference.md §6.3). No rclpy.

Moving obstacles come from several places — move_base's own tracker, other nodes that publish on the local
planner's ``obstacles`` topic — and go to several users: both costmaps (to clear the marks a moving obstacle
leaves) and the local planner (to predict them). An ``ObstacleSource`` answers in its own frame; an
``ObstacleFeed`` merges sources and answers in the frame asked for. The feed is handed explicitly to the costmaps
and to every local planner at construction, so no user reaches into another for its obstacles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from simplebot_navigation.geometry import transform_points

#: (x, y, yaw) of the source frame in the target frame, or None when it is not known (then the source is skipped)
Transform = Callable[[str, str], "tuple[float, float, float] | None"]


@dataclass(frozen=True)
class MovingObstacles:
    """K moving obstacles in `frame`, positions as of `stamp`: rows (K, 5) x, y, vx, vy, radius and each one's
    covariance (K, 4, 4) over x, y, vx, vy (zeros: the source gives none)."""
    frame: str
    stamp: float
    rows: np.ndarray
    covariance: np.ndarray

    @classmethod
    def empty(cls, frame: str, stamp: float) -> MovingObstacles:
        return cls(frame, float(stamp), np.empty((0, 5)), np.empty((0, 4, 4)))

    def __len__(self) -> int:
        return len(self.rows)

    def transformed(self, transform: tuple[float, float, float], frame: str) -> MovingObstacles:
        """The same obstacles in `frame`, given where this frame lies in it: positions moved, velocities and
        covariances rotated."""
        yaw = transform[2]
        rows = self.rows.copy()
        rows[:, 0:2] = transform_points(transform, self.rows[:, 0:2])
        rows[:, 2:4] = transform_points((0.0, 0.0, yaw), self.rows[:, 2:4])
        c, s = math.cos(yaw), math.sin(yaw)
        block = np.kron(np.eye(2), np.array([[c, -s], [s, c]]))     # rotates x, y and vx, vy alike
        return MovingObstacles(frame, self.stamp, rows, block @ self.covariance @ block.T)

    @classmethod
    def concatenate(cls, parts: list[MovingObstacles], frame: str, stamp: float) -> MovingObstacles:
        if not parts:
            return cls.empty(frame, stamp)
        return cls(frame, float(stamp), np.concatenate([p.rows for p in parts]),
                   np.concatenate([p.covariance for p in parts]))


class ObstacleSource(Protocol):
    """One origin of moving obstacles (move_base's tracker, another node's publications)."""

    #: the frame its answers are in ("" before it knows one: then it has nothing to say)
    frame: str

    def moving_obstacles(self, now: float) -> MovingObstacles:
        """Its moving obstacles with positions predicted to `now` (node time, s), in ``frame``."""

    def clearing_circles(self, now: float) -> np.ndarray:
        """(K, 3) circles x, y, radius in ``frame`` whose marks the costmaps should clear at `now`."""


class MovingObstacleFeed(Protocol):
    """What the costmaps and the local planners are given: every source's answer in the frame they work in."""

    def moving_obstacles(self, now: float, frame: str) -> MovingObstacles:
        """Every moving obstacle at `now`, in `frame`."""

    def clearing_circles(self, now: float, frame: str) -> np.ndarray:
        """(K, 3) circles x, y, radius in `frame` to clear at `now`."""


class ObstacleFeed:
    """Sources merged, each answer moved into the frame asked for by `transform` (a source whose frame cannot
    be transformed right now contributes nothing this time; `transform` says why, the feed does not)."""

    def __init__(self, transform: Transform, sources: tuple[ObstacleSource, ...] = ()):
        self.transform = transform
        self.sources: list[ObstacleSource] = list(sources)

    def add(self, source: ObstacleSource) -> None:
        self.sources.append(source)

    def _placed(self, frame: str):
        """(source, its transform into frame or None for the identity) for the sources that can be placed."""
        for source in self.sources:
            if not source.frame:
                continue
            if source.frame == frame:
                yield source, None
                continue
            transform = self.transform(frame, source.frame)
            if transform is not None:
                yield source, transform

    def moving_obstacles(self, now: float, frame: str) -> MovingObstacles:
        parts = []
        for source, transform in self._placed(frame):
            obstacles = source.moving_obstacles(now)
            if len(obstacles):
                parts.append(obstacles if transform is None else obstacles.transformed(transform, frame))
        return MovingObstacles.concatenate(parts, frame, now)

    def clearing_circles(self, now: float, frame: str) -> np.ndarray:
        parts = []
        for source, transform in self._placed(frame):
            circles = source.clearing_circles(now)
            if len(circles) and transform is not None:
                circles = np.column_stack([transform_points(transform, circles[:, :2]), circles[:, 2]])
            parts.append(circles)
        return np.concatenate(parts) if parts else np.empty((0, 3))
