"""What one update's clusters say about where the tracked obstacles' centres are, and how surely
(docs/reference.md §6.1, step 5).

A whole outline measures the centre directly; an outline cut by something nearer, the field's edge or the range
limit measures it by a circle fitted to the visible arc. Each measurement carries a covariance that says what the
outline cannot show: a whole outline of another size than the track's, or the hidden end of a cut one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplebot_navigation.perception import tracking_kernels
from simplebot_navigation.perception.params import TrackerParams
from simplebot_navigation.perception.segmentation import FIT_DAMPING, FIT_ITERATIONS, FIXED_INFORMATION, Clusters

#: the smallest radius reported
MIN_RADIUS = 0.05
#: a cut cluster whose returns lie farther than this (RMS) from the circle fitted to them is no arc of the track
FIT_RMS = 0.02
#: a fitted centre counts no closer than this (1 sigma, metres) in any direction
FIT_FLOOR = 0.01
#: a radius fitted to a cut outline counts when its sigma is at most this (metres)
FIT_RADIUS_SIGMA = 0.05
#: a fitted centre is used within this normalised squared distance of the prediction (chi-square, 2 dof: 99 %)
FIT_GATE = 9.21
#: the centre of an outline cut by something nearer or the field's edge, along the visible arc's chord, 1 sigma,
#: as a share of the hidden part (the diameter less the chord): where that ends is unknown, and a sliver slides
#: along its chord as the sensor passes the thing in front (a tree coming out from behind another read as walking
#: at 1-4 m/s)
CUT_ALONG = 0.25


@dataclass
class Measurements:
    """tracks (M,): indices into the tracks given; centre (M, 2) and noise (M, 2, 2); learnt (L,) tracks whose
    radius a cut arc fixed for the first time, learnt_radius (L,)."""
    tracks: np.ndarray
    centre: np.ndarray
    noise: np.ndarray
    learnt: np.ndarray
    learnt_radius: np.ndarray


def centres(clusters: Clusters, cluster_of: np.ndarray, points: np.ndarray, predicted: np.ndarray,
            predicted_cov: np.ndarray, radius: np.ndarray, radius_known: np.ndarray,
            params: TrackerParams) -> Measurements:
    """The measurements of T seen tracks, track t by cluster cluster_of[t], given each track's predicted centre
    (T, 2) and its covariance (T, 2, 2), its radius (T,) and whether that is known (T,). A cut cluster is fitted a
    circle of the track's radius once that is known, else of the radius that fits (kept when the arc fixes it to
    FIT_RADIUS_SIGMA); a fit off the circle, off the prediction or of no obstacle's size measures nothing."""
    occluded = clusters.occluded[cluster_of]
    whole, cut = np.flatnonzero(~occluded), np.flatnonzero(occluded & ~clusters.unfit[cluster_of])
    # An outline of another size than the track's (a thing coming out from behind a corner grows) places its
    # centre less surely, by the difference beyond the noise of a whole outline's size (about its centre's).
    mismatch = np.maximum(np.abs(clusters.radius[cluster_of[whole]] - radius[whole]) - params.measurement_noise, 0.0)
    measured = [clusters.centre[cluster_of[whole]]]
    noise = [np.eye(2) * (params.measurement_noise ** 2 + mismatch ** 2)[:, None, None]]
    learnt, learnt_radius = np.empty(0, dtype=np.int64), np.empty(0)
    if len(cut):
        k, known = cluster_of[cut], radius_known[cut]
        centre, cov, fitted, fitted_sigma, rms = tracking_kernels.fit_circles(
            points, clusters.first[k], clusters.last[k], radius[cut], known, predicted[cut],
            max(params.range_noise, FIT_FLOOR), FIT_ITERATIONS, FIT_DAMPING, FIXED_INFORMATION)
        good = (rms <= FIT_RMS) & np.isfinite(centre).all(axis=1) & (fitted_sigma <= FIT_RADIUS_SIGMA) & \
            (fitted >= MIN_RADIUS) & (fitted <= 0.5 * params.max_obstacle_size) & \
            (normalised_squared(centre - predicted[cut], predicted_cov[cut] + cov) <= FIT_GATE)
        learnt, learnt_radius = cut[good & ~known], fitted[good & ~known]
        cut, k = cut[good], k[good]
        chord = points[clusters.last[k]] - points[clusters.first[k]]
        chord_length = np.hypot(*chord.T)
        along = chord / np.maximum(chord_length, 1e-9)[:, None]
        hidden = np.maximum(2.0 * np.where(known[good], radius[cut], fitted[good]) - chord_length, 0.0)
        sigma = np.where(clusters.range_cut[k], 0.0, CUT_ALONG * hidden)
        measured.append(centre[good])
        noise.append(cov[good] + np.eye(2) * FIT_FLOOR ** 2 +
                     sigma[:, None, None] ** 2 * along[:, :, None] * along[:, None, :])
    return Measurements(np.concatenate([whole, cut]), np.concatenate(measured), np.concatenate(noise), learnt,
                        learnt_radius)


def normalised_squared(offset: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """(M,) offset^T cov^-1 offset of (M, 2) offsets with (M, 2, 2) covariances."""
    return np.einsum("mi,mij,mj->m", offset, np.linalg.inv(cov), offset)
