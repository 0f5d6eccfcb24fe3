"""Clusters of particles and the pose estimate amcl reports from them.

As amcl's pf_cluster_stats: the particles fill a histogram of 0.5 m x 0.5 m x 10 deg bins (the KLD bins); bins that
touch, faces, edges or corners, form one cluster. Each cluster has its weight, its weighted mean (yaw as the
circular mean) and covariance (x, y linear; yaw's variance -2 ln R, R the mean resultant length). The estimate
is the mean of the heaviest cluster; its covariance is the whole filter's, which is what amcl publishes (the
cluster's own is kept beside it). Unlike amcl, yaw bins wrap around at +-pi, so a cloud facing west is one
cluster, not two.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

BIN_XY = 0.5
BIN_YAW = math.radians(10.0)
YAW_BINS = round(2 * math.pi / BIN_YAW)
_OFFSETS = np.array([(dx, dy, da) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for da in (-1, 0, 1)
                     if (dx, dy, da) != (0, 0, 0)])


def bins_of(poses: np.ndarray) -> np.ndarray:
    """(N, 3) integer bin of each pose: x and y in BIN_XY, yaw in BIN_YAW counted from -pi, wrapped."""
    return np.column_stack((np.floor(poses[:, 0] / BIN_XY), np.floor(poses[:, 1] / BIN_XY),
                            np.floor((poses[:, 2] + math.pi) / BIN_YAW) % YAW_BINS)).astype(np.int64)


def _packed(bins: np.ndarray) -> np.ndarray:
    return ((bins[:, 0] + (1 << 20)) << 42) | ((bins[:, 1] + (1 << 20)) << 21) | (bins[:, 2] % YAW_BINS)


def cluster_labels(poses: np.ndarray) -> tuple[np.ndarray, int]:
    """(cluster of each particle, number of clusters): connected components of the filled bins."""
    keys, inverse = np.unique(_packed(bins_of(poses)), return_inverse=True)
    occupied = _bins_of_keys(keys)
    rows, cols = [], []
    for offset in _OFFSETS:
        neighbour = _packed(occupied + offset)
        at = np.searchsorted(keys, neighbour)
        found = (at < len(keys)) & (keys[np.minimum(at, len(keys) - 1)] == neighbour)
        rows.append(np.nonzero(found)[0])
        cols.append(at[found])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(keys), len(keys)))
    count, bin_label = connected_components(graph, directed=False)
    return bin_label[inverse.ravel()], count


def _bins_of_keys(keys: np.ndarray) -> np.ndarray:
    """The (x, y, yaw) bins of packed keys."""
    mask = (1 << 21) - 1
    return np.column_stack(((keys >> 42) - (1 << 20), ((keys >> 21) & mask) - (1 << 20), keys & mask))


def weighted_stats(poses: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mean (x, y, yaw), 3x3 covariance) of weighted poses as amcl computes them: x, y linear, yaw circular,
    no x-yaw or y-yaw terms."""
    total = weights.sum()
    mean_xy = weights @ poses[:, :2] / total
    cos_sum, sin_sum = weights @ np.cos(poses[:, 2]), weights @ np.sin(poses[:, 2])
    centred = poses[:, :2] - mean_xy
    cov = np.zeros((3, 3))
    cov[:2, :2] = (centred * weights[:, None]).T @ centred / total
    resultant = min(math.hypot(cos_sum, sin_sum) / total, 1.0)
    cov[2, 2] = -2.0 * math.log(resultant) if resultant > 0 else math.inf
    return np.array([*mean_xy, math.atan2(sin_sum, cos_sum)]), cov


@dataclass(frozen=True)
class PoseEstimate:
    """The filter's answer: the heaviest cluster's mean, with amcl's covariance (of the whole filter)."""
    x: float
    y: float
    yaw: float
    covariance: np.ndarray           # 3x3 (x, y, yaw) of all particles, as amcl publishes it
    cluster_covariance: np.ndarray   # 3x3 of the heaviest cluster alone
    weight: float                    # the heaviest cluster's share of the weight
    clusters: int
    particles: int

    def ros_covariance(self) -> list[float]:
        """The 36 row-major entries of geometry_msgs/PoseWithCovariance's covariance (x, y, z, roll, pitch, yaw),
        filled as amcl fills amcl_pose: the x-y block and yaw's variance."""
        return covariance_to_ros(self.covariance)


def covariance_to_ros(cov3: np.ndarray) -> list[float]:
    """3x3 (x, y, yaw) -> 6x6 row-major: the x-y block and the yaw variance, the rest zero."""
    out = np.zeros((6, 6))
    out[:2, :2] = cov3[:2, :2]
    out[5, 5] = cov3[2, 2]
    return out.ravel().tolist()


def covariance_from_ros(cov36) -> np.ndarray:
    """6x6 row-major (e.g. /initialpose) -> 3x3 (x, y, yaw) as amcl reads it: the x-y block and the yaw variance."""
    cov6 = np.asarray(cov36, dtype=float).reshape(6, 6)
    out = np.zeros((3, 3))
    out[:2, :2] = cov6[:2, :2]
    out[2, 2] = cov6[5, 5]
    return out


def estimate(poses: np.ndarray, weights: np.ndarray) -> PoseEstimate:
    """The pose estimate of weighted particles."""
    labels, count = cluster_labels(poses)
    cluster_weights = np.bincount(labels, weights=weights, minlength=count)
    best = int(np.argmax(cluster_weights))
    members = labels == best
    mean, cluster_cov = weighted_stats(poses[members], weights[members])
    _, cov = weighted_stats(poses, weights)
    return PoseEstimate(float(mean[0]), float(mean[1]), float(mean[2]), cov, cluster_cov,
                        float(cluster_weights[best] / weights.sum()), count, len(poses))
