"""Feasibility of the start of a band against the costmap footprint (docs/reference.md §4.5 step 9).

Each checked pose gets base_local_planner's footprint cost (costmap/footprint.py footprint_costs);
only -1 (a lethal cell met first on the outline) makes a band infeasible.
"""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.costmap.footprint import footprint_costs
from simplebot_navigation.geometry import normalize_theta


def is_trajectory_feasible(costmap, footprint, inscribed_radius: float, poses: np.ndarray,
                           no_poses: int, lookahead_distance: float, min_angular_resolution: float) -> bool:
    """Check the first ``no_poses`` band poses (fewer if lookahead_distance > 0 is reached first),
    inserting intermediate poses where consecutive ones are farther apart than the inscribed radius
    or turn more than min_angular_resolution."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    look = min(no_poses, len(poses) - 1)
    if lookahead_distance > 0:
        travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
        beyond = np.nonzero(travelled > lookahead_distance)[0]
        if len(beyond):
            look = min(look, int(beyond[0]))
    look = max(look, 0)
    check = [poses[: look + 1]]
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
    return not bool(np.any(footprint_costs(costmap, footprint, np.vstack(check)) == -1.0))

