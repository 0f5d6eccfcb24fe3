"""Perception's limit: the simulator's true moving obstacles as move_base's obstacle source, instead of its tracker.

A campaign run with ``true_obstacles`` (``--true-obstacles``) hands the local planner and the costmaps every moving
obstacle within the lidars' range exactly where it is and as fast as it goes, seen or hidden; the tracker still
runs, and the collision monitor still reads its tracks. Set beside an ordinary run of the same worlds, it splits
what the robot loses to its perception from what it loses to its planner. No rclpy.
"""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.perception.feed import MovingObstacles

#: the lidars' range (m, the simulated Hokuyos' range_max): obstacles beyond it are not handed on
SENSOR_RANGE_M = 5.6
#: the costmaps clear where an obstacle is and was within this long (s), its radius widened by CLEARING_MARGIN_M,
#: as the tracker's clearing_time and clearing_margin do
CLEARING_TIME_S = 0.5
CLEARING_MARGIN_M = 0.15


class TrueObstacles:
    """An ObstacleSource (perception/feed.py) in the robot's odometry frame ``frame``.

    The obstacles are placed relative to the robot's true pose and that relation is kept in odometry, so a robot
    whose odometry drifted (a walker pushed it) still sees each obstacle where it truly is relative to itself."""

    def __init__(self, sim, frame: str, robot: int = 0):
        self.sim, self.frame, self.robot = sim, frame, robot
        self._history: list[tuple[float, np.ndarray]] = []     # (time, circles) for clearing

    def _rows(self) -> np.ndarray:
        """(K, 5) x, y, vx, vy, radius in odometry of the moving obstacles within SENSOR_RANGE_M."""
        truth, odom = self.sim.ground_truth(self.robot), self.sim.odometry(self.robot)
        turn = odom.yaw - truth.yaw
        c, s = math.cos(turn), math.sin(turn)
        rows = []
        for state in self.sim.moving_obstacle_states():
            radius = state.extent if state.shape == "cylinder" else math.hypot(*state.extent) / 2
            dx, dy = state.x - truth.x, state.y - truth.y
            if math.hypot(dx, dy) - radius <= SENSOR_RANGE_M:
                rows.append((odom.x + c * dx - s * dy, odom.y + s * dx + c * dy,
                             c * state.vx - s * state.vy, s * state.vx + c * state.vy, radius))
        return np.array(rows, dtype=float).reshape(-1, 5)

    def moving_obstacles(self, now: float) -> MovingObstacles:
        rows = self._rows()
        return MovingObstacles(self.frame, now, rows, np.zeros((len(rows), 4, 4)))

    def clearing_circles(self, now: float) -> np.ndarray:
        rows = self._rows()
        self._history = [(t, c) for t, c in self._history if now - CLEARING_TIME_S <= t <= now]
        self._history.append((now, np.column_stack([rows[:, :2], rows[:, 4] + CLEARING_MARGIN_M])))
        return np.concatenate([c for _, c in self._history])


def use_true_obstacles(move_base, sim) -> None:
    """The simulator's moving obstacles take the tracker's place in move_base's obstacle feed."""
    if not move_base.obstacle_tracking.params.enabled:
        raise ValueError("true_obstacles needs moving obstacles on (it replaces what the tracker hands on)")
    feed = move_base.obstacle_feed
    truth = TrueObstacles(sim, move_base.local_costmap.global_frame)
    feed.sources = [truth if source is move_base.obstacle_tracking else source for source in feed.sources]
