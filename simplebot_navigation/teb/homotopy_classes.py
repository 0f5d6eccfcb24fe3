"""Homotopy classes of bands, simple version (docs/reference.md §4.7, §4.8): the signature of a band
around the static obstacle clusters and around the moving obstacles, and where to seed bands
of other classes.

Static: lethal cells are grouped into clusters (cells closer than the robot can pass between),
each represented by one key point, and a band's class is the vector of angles it sweeps around
those key points: two bands with the same start and goal are in the same class when every swept
angle agrees to within pi.

Moving (TEB's (x, y, t) H-signature, simplified): a band passes a moving obstacle on one side of
the obstacle's track in space and time. Seen from the obstacle -- the band's poses less the
obstacle's centre predicted at each pose's time -- the band sweeps an angle whose sign is that
side: passing in front of a crossing obstacle and behind it, or left and right of an oncoming
one, sweep opposite angles. Two bands differ in class when, for some moving obstacle, both sweep
at least MOVING_SIGNATURE_THRESHOLD and with opposite signs (one that stays far from both bands
sweeps little and does not separate them, as TEB's h_signature_threshold).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.perception.prediction import MotionPrediction

#: Swept angle [rad] below which a moving obstacle does not separate two classes: a tenth of a
#: turn, TEB's default h_signature_threshold of a normalised H-signature.
MOVING_SIGNATURE_THRESHOLD = 0.2 * math.pi


class Signature(NamedTuple):
    static: np.ndarray          # angle swept around each cluster key point
    moving: np.ndarray          # angle swept around each moving obstacle, seen from the obstacle


EMPTY_SIGNATURE = Signature(np.zeros(0), np.zeros(0))


def obstacle_clusters(obstacles: np.ndarray, gap: float) -> list[np.ndarray]:
    """Group point obstacles on a coarse grid of cell size ``gap`` (8-connected): points less than
    ``gap`` apart always share a cluster, points farther than 2*sqrt(2)*gap never do directly."""
    if len(obstacles) == 0:
        return []
    lo = obstacles.min(axis=0)
    ij = np.floor((obstacles - lo) / gap).astype(np.int64)
    grid = np.zeros(ij.max(axis=0) + 1, dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    labels, count = ndimage.label(grid, structure=np.ones((3, 3), dtype=bool))
    point_label = labels[ij[:, 0], ij[:, 1]] - 1
    order = np.argsort(point_label, kind="stable")
    splits = np.searchsorted(point_label[order], np.arange(1, count))
    return [obstacles[idx] for idx in np.split(order, splits)]


def cluster_keypoint(points: np.ndarray) -> np.ndarray:
    """The member closest to the centroid: a point that lies on the obstacle itself."""
    c = points.mean(axis=0)
    return points[np.argmin(((points - c) ** 2).sum(axis=1))]


def homotopy_signature(path_xy: np.ndarray, keypoints: np.ndarray) -> np.ndarray:
    """Angle swept around each key point while travelling along the path (winding, not wrapped)."""
    if len(keypoints) == 0:
        return np.zeros(0)
    ang = np.arctan2(path_xy[:, None, 1] - keypoints[None, :, 1], path_xy[:, None, 0] - keypoints[None, :, 0])
    return normalize_theta(np.diff(ang, axis=0)).sum(axis=0)


def moving_signature(path_xy: np.ndarray, times: np.ndarray, moving: np.ndarray,
                     prediction: MotionPrediction = MotionPrediction()) -> np.ndarray:
    """Angle swept by the path around each moving obstacle (prediction rows, or rows x, y, vx, vy,
    radius), the path taken relative to the obstacle's centre predicted at each point's time."""
    if len(moving) == 0:
        return np.zeros(0)
    rel = path_xy[None, :, :] - prediction.centres(moving, times)
    return normalize_theta(np.diff(np.arctan2(rel[..., 1], rel[..., 0]), axis=1)).sum(axis=1)


def path_times(path_xy: np.ndarray, speed: float) -> np.ndarray:
    """Time at each point of a path driven at constant speed (a plan has no time of its own)."""
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path_xy, axis=0).T))]) / speed


def same_class(sig_a: Signature, sig_b: Signature) -> bool:
    if len(sig_a.static) != len(sig_b.static) or len(sig_a.moving) != len(sig_b.moving):
        return False
    if not np.all(np.abs(sig_a.static - sig_b.static) < math.pi):
        return False
    both = (np.abs(sig_a.moving) >= MOVING_SIGNATURE_THRESHOLD) & (np.abs(sig_b.moving) >= MOVING_SIGNATURE_THRESHOLD)
    return not np.any(both & (np.sign(sig_a.moving) != np.sign(sig_b.moving)))


def moving_detours(start: np.ndarray, axis: np.ndarray, length: float, moving: np.ndarray, speed: float):
    """Where a robot driving the start-goal line at ``speed`` meets each moving obstacle: per
    obstacle, (distance along the line, lateral offset from it) of the obstacle's centre predicted
    at the time of their closest approach, and the obstacle's radius. Seeds passing left and right
    of those points are the bands in front of and behind a crossing obstacle, or either side of an
    oncoming one."""
    if len(moving) == 0:
        return np.zeros((0, 3))
    rel = start[None, :2] - moving[:, :2]
    closing = speed * axis[None, :] - moving[:, 2:4]                       # the robot's velocity, seen from each
    norm2 = np.maximum((closing ** 2).sum(axis=1), 1e-12)
    t = np.clip(-(rel * closing).sum(axis=1) / norm2, 0.0, length / speed)
    meet = moving[:, :2] + t[:, None] * moving[:, 2:4] - start[None, :2]
    normal = np.array([-axis[1], axis[0]])
    return np.column_stack([meet @ axis, meet @ normal, moving[:, 4]])
