"""The timed elastic band: SE(2) poses s_0..s_n and time differences dT_0..dT_{n-1} (docs/reference.md §4.1).

Pose 0 (the robot) and pose n (the local goal) are fixed during optimisation.
"""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.teb.edge_kernels import MIN_TIME_DIFF

#: a band segment shorter than this (m) is a turn on the spot: its time is not scaled by the distance
#: still to drive at a warm start
MIN_SCALED_SEGMENT = 1e-3


def estimate_delta_t(p0, p1, max_vel_x: float, max_vel_theta: float) -> float:
    """Time for a constant-velocity move from p0 to p1 at the velocity limits."""
    dt = 0.1
    if max_vel_x > 0:
        dt = math.hypot(p1[0] - p0[0], p1[1] - p0[1]) / max_vel_x
    if max_vel_theta > 0:
        dt = max(dt, abs(float(normalize_theta(p1[2] - p0[2]))) / max_vel_theta)
    return dt


def average_pose(p0, p1):
    return np.array([(p0[0] + p1[0]) / 2, (p0[1] + p1[1]) / 2,
                     float(normalize_theta(p0[2] + normalize_theta(p1[2] - p0[2]) / 2))])


class TimedElasticBand:
    def __init__(self, poses: np.ndarray | None = None, time_diffs: np.ndarray | None = None):
        self.poses = np.zeros((0, 3)) if poses is None else np.asarray(poses, dtype=float).reshape(-1, 3).copy()
        self.time_diffs = np.zeros(0) if time_diffs is None else np.asarray(time_diffs, dtype=float).copy()
        if len(self.poses) and len(self.time_diffs) != len(self.poses) - 1:
            raise ValueError(f"band needs len(time_diffs) == len(poses) - 1, got {len(self.time_diffs)} "
                             f"and {len(self.poses)}")

    @property
    def is_init(self) -> bool:
        return len(self.poses) > 0

    def clear(self) -> None:
        self.poses = np.zeros((0, 3))
        self.time_diffs = np.zeros(0)

    def copy(self) -> "TimedElasticBand":
        return TimedElasticBand(self.poses, self.time_diffs)

    @property
    def time_stamps(self) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(self.time_diffs)])

    @property
    def sum_of_time_diffs(self) -> float:
        return float(self.time_diffs.sum())

    def init_from_path(self, path: np.ndarray, max_vel_x: float, max_vel_theta: float,
                       estimate_orientation: bool, min_samples: int, guess_backwards_motion: bool) -> None:
        """One pose per plan point with constant-velocity time differences; the ends keep
        the given start and goal poses. Orientation of intermediate poses is the plan's
        direction when ``estimate_orientation`` (global_plan_overwrite_orientation)."""
        path = np.asarray(path, dtype=float).reshape(-1, 3)
        if len(path) < 2:
            raise ValueError(f"band initialisation needs a start and a goal, got {len(path)} plan poses")
        start, goal = path[0], path[-1]
        backwards = guess_backwards_motion and (
            (goal[0] - start[0]) * math.cos(start[2]) + (goal[1] - start[1]) * math.sin(start[2]) < 0)
        mid = path[1:-1].copy()
        if estimate_orientation and len(mid):
            d = path[2:, :2] - path[1:-1, :2]
            mid[:, 2] = np.arctan2(d[:, 1], d[:, 0]) + (math.pi if backwards else 0.0)
            mid[:, 2] = normalize_theta(mid[:, 2])
        poses = [start, *mid]
        while len(poses) < min_samples - 1:
            poses.append(average_pose(poses[-1], goal))
        poses.append(goal)
        poses = np.array(poses)
        self.poses = poses
        # repeated plan poses (a turn on the spot) would give dT = 0, which the optimiser divides by
        self.time_diffs = np.maximum([estimate_delta_t(poses[i], poses[i + 1], max_vel_x, max_vel_theta)
                                      for i in range(len(poses) - 1)], MIN_TIME_DIFF)

    def update_and_prune(self, new_start, new_goal, min_samples: int) -> None:
        """Warm start: drop the poses the robot has passed (searching up to 10 ahead for the
        nearest), then pin the new start and goal.

        The new first segment, from the robot to the first pose kept, gets the time the old band
        planned for that stretch: the time of the old segment it lies on (from the nearest pose on),
        scaled by the share of that segment still to drive. TEB keeps the old first segment's time
        whatever the robot drove meanwhile, so the first segment's speed swings with where the robot
        happens to stand between two poses (at 2 m/s and 20 Hz it passes 2/3 of a 0.075 s segment
        per cycle: half the cycles a dip, the others a spike), and the command, which is that speed,
        alternates between braking and speeding up (see tests/teb/test_braking.py)."""
        if new_start is not None and self.is_init:
            dist = np.hypot(self.poses[:, 0] - new_start[0], self.poses[:, 1] - new_start[1])
            lookahead = min(len(self.poses) - min_samples, 10)
            nearest = 0
            for i in range(1, lookahead + 1):
                if dist[i] < dist[nearest]:
                    nearest = i
                else:
                    break
            first_dt = None
            if len(self.time_diffs) > nearest:
                length = math.hypot(*(self.poses[nearest + 1, :2] - self.poses[nearest, :2]))
                first_dt = float(self.time_diffs[nearest])
                if length > MIN_SCALED_SEGMENT:
                    ahead = math.hypot(*(self.poses[nearest + 1, :2] - np.asarray(new_start[:2], dtype=float)))
                    first_dt = max(first_dt * ahead / length, MIN_TIME_DIFF)
            if nearest > 0:
                self.poses = np.delete(self.poses, np.s_[1:nearest + 1], axis=0)
                self.time_diffs = np.delete(self.time_diffs, np.s_[1:nearest + 1])
            self.poses[0] = new_start
            if first_dt is not None:
                self.time_diffs[0] = first_dt
        if new_goal is not None and self.is_init:
            self.poses[-1] = new_goal

    def auto_resize(self, dt_ref: float, dt_hysteresis: float, min_samples: int, max_samples: int,
                    fast_mode: bool) -> None:
        """Split long intervals and merge short ones so every dT stays near dt_ref.
        fast_mode runs a single pass (TEB does so unless dynamic obstacles are enabled)."""
        poses = [p for p in self.poses]
        dts = list(self.time_diffs)
        for _ in range(100):
            modified = False
            i = 0
            while i < len(dts):
                if dts[i] > dt_ref + dt_hysteresis and len(dts) < max_samples:
                    if dts[i] > 2 * dt_ref:
                        half = 0.5 * dts[i]
                        dts[i] = half
                        poses.insert(i + 1, average_pose(poses[i], poses[i + 1]))
                        dts.insert(i + 1, half)
                        modified = True
                        continue  # re-check the halved interval
                    if i > 0:
                        # upstream's retiming to dt_ref, the surplus to the next interval (poses stay)
                        if i < len(dts) - 1:
                            dts[i + 1] += dts[i] - dt_ref
                        dts[i] = dt_ref
                elif dts[i] < dt_ref - dt_hysteresis and len(dts) > min_samples:
                    if i < len(dts) - 1:
                        dts[i + 1] += dts[i]
                        del dts[i]
                        del poses[i + 1]
                        modified = True
                        continue
                    dts[i - 1] += dts[i]
                    del dts[i]
                    del poses[i]
                    modified = True
                    continue
                i += 1
            if fast_mode or not modified:
                break
        self.poses = np.array(poses)
        self.time_diffs = np.array(dts)
