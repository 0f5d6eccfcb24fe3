"""Feasibility of the start of a band against the costmap footprint (docs/reference.md §4.5 step 9).

Each checked pose gets base_local_planner's footprint cost (costmap/footprint.py footprint_costs);
only -1 (a lethal cell met first on the outline) makes a band infeasible. Moving obstacles are
checked at the same poses, each where it is predicted at the pose's time (docs/reference.md §4.8).
"""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.costmap.footprint import footprint_costs
from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.perception.prediction import MotionPrediction
from simplebot_navigation.teb.footprint import FootprintModel


def collision_model(footprint: np.ndarray, inscribed_radius: float) -> FootprintModel:
    """The costmap footprint as a footprint model, to measure moving obstacles against: its
    outline, or for fewer than three points the inscribed circle the static check stands for."""
    if len(footprint) >= 3:
        return FootprintModel.polygon(footprint)
    return FootprintModel.circular(inscribed_radius)


def is_trajectory_feasible(costmap, footprint, inscribed_radius: float, poses: np.ndarray,
                           no_poses: int, lookahead_distance: float, min_angular_resolution: float,
                           time_stamps: np.ndarray | None = None, dynamic_obstacles: np.ndarray | None = None,
                           model: FootprintModel | None = None,
                           prediction: MotionPrediction = MotionPrediction()) -> bool:
    """Check the first ``no_poses`` band poses (fewer if lookahead_distance > 0 is reached first),
    inserting intermediate poses where consecutive ones are farther apart than the inscribed radius
    or turn more than min_angular_resolution. With dynamic_obstacles (prediction rows, or (K, 5): x, y,
    vx, vy, radius), a checked pose also fails when ``model`` (collision_model) overlaps an obstacle's
    keep-out circle where ``prediction`` puts it at the pose's time (time_stamps of the band poses;
    inserted poses interpolate)."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    times = np.zeros(len(poses)) if time_stamps is None else np.asarray(time_stamps, dtype=float)
    checked, checked_times = _checked_poses(poses, times, _look(poses, no_poses, lookahead_distance),
                                            inscribed_radius, min_angular_resolution)
    if np.any(footprint_costs(costmap, footprint, checked) == -1.0):
        return False
    if dynamic_obstacles is None or len(dynamic_obstacles) == 0:
        return True
    centres = prediction.centres(dynamic_obstacles, checked_times)                    # K, P, 2
    k = len(dynamic_obstacles)
    d = model.pair_distances(np.tile(checked, (k, 1)), centres.reshape(-1, 2)).reshape(k, -1)
    return not bool(np.any(d < prediction.radii(dynamic_obstacles, checked_times)))


def _look(poses: np.ndarray, no_poses: int, lookahead_distance: float) -> int:
    """Index of the last pose to check."""
    look = min(no_poses, len(poses) - 1)
    if lookahead_distance > 0:
        travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
        beyond = np.nonzero(travelled > lookahead_distance)[0]
        if len(beyond):
            look = min(look, int(beyond[0]))
    return max(look, 0)


def _checked_poses(poses, times, look: int, inscribed_radius: float, min_angular_resolution: float):
    """Poses 0..look with the intermediate poses appended, and the time of each."""
    check, check_times = [poses[: look + 1]], [times[: look + 1]]
    for i in range(look):
        d_rot = float(normalize_theta(poses[i + 1, 2] - poses[i, 2]))
        d_pos = poses[i + 1, :2] - poses[i, :2]
        dist = math.hypot(*d_pos)
        if abs(d_rot) > min_angular_resolution or dist > inscribed_radius:
            extra = int(max(math.ceil(abs(d_rot) / min_angular_resolution),
                            math.ceil(dist / inscribed_radius) if inscribed_radius > 0 else 1)) - 1
            if extra > 0:
                f = np.arange(1, extra + 1)[:, None] / (extra + 1.0)
                mid = np.empty((extra, 3))
                mid[:, :2] = poses[i, :2] + f * d_pos
                mid[:, 2] = normalize_theta(poses[i, 2] + f[:, 0] * d_rot)
                check.append(mid)
                check_times.append(times[i] + f[:, 0] * (times[i + 1] - times[i]))
    return np.vstack(check), np.concatenate(check_times)
