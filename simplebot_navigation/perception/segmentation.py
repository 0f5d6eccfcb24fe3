"""One planar scan cut into clusters, each a candidate obstacle with a centre and a radius (docs/reference.md §6).

Neighbouring returns belong to one cluster unless they lie farther apart than the adaptive breakpoint
distance, which grows with range and beam spacing: r sin(dphi) / sin(lambda - dphi) + 3 sigma (Borges and
Aldon's rule: a surface seen flatter than lambda breaks up), and always across more than one beam
without a return. A cluster end is *occluded* when the beam next to
it hit something nearer, when it is the first or last beam of the scan, or when it lies near range_max: its
outline is cut there, so its centre moves with the occluder, not with itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a cluster end within this of range_max is cut by the range limit
#: beams without a return a cluster may span (more: a gap beyond the range limit lies between)
MAX_MISSING_BEAMS = 1
RANGE_LIMIT_MARGIN = 0.3
#: Gauss-Newton steps of the known-radius circle fit
FIT_ITERATIONS = 4
#: Levenberg damping of the fit's steps, in returns' worth of information in every direction
FIT_DAMPING = 0.5


@dataclass
class Scan:
    """One planar scan in the tracking frame: the sensor position and, in beam order, each beam's bearing
    (in the tracking frame) and range. A range outside [range_min, range_max), or not finite, is no return."""
    origin: np.ndarray
    angles: np.ndarray
    ranges: np.ndarray
    range_min: float
    range_max: float

    @classmethod
    def from_laser(cls, ranges, angle_min: float, angle_increment: float, range_min: float, range_max: float,
                   x: float, y: float, yaw: float) -> Scan:
        """A LaserScan taken by a sensor at (x, y, yaw) in the tracking frame."""
        r = np.asarray(ranges, dtype=float).reshape(-1)
        angles = yaw + angle_min + angle_increment * np.arange(len(r))
        return cls(np.array([x, y], dtype=float), angles, r, float(range_min), float(range_max))

    def points(self) -> np.ndarray:
        """(N, 2) every beam's return in the tracking frame; NaN for a beam without one."""
        r = np.where(self.valid(), self.ranges, np.nan)
        return self.origin + r[:, None] * np.stack([np.cos(self.angles), np.sin(self.angles)], axis=1)

    def valid(self) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return np.isfinite(self.ranges) & (self.ranges >= max(self.range_min, 0.0)) & \
                (self.ranges < self.range_max)


@dataclass
class Clusters:
    """K clusters: centre (K, 2), radius (K,), width (K,), count (K,), occluded (K,), structure (K,): the
    share of each cluster's returns that lie on structure (StructureMap), and first, last (K,): the beams of its
    outer returns (numbered on from `first_beam` of segment(), so that clusters of several scans index their
    concatenated points)."""
    centre: np.ndarray
    radius: np.ndarray
    width: np.ndarray
    count: np.ndarray
    occluded: np.ndarray
    structure: np.ndarray
    first: np.ndarray
    last: np.ndarray

    _FIELDS = ("centre", "radius", "width", "count", "occluded", "structure", "first", "last")

    @classmethod
    def empty(cls) -> Clusters:
        return cls(np.empty((0, 2)), np.empty(0), np.empty(0), np.empty(0, dtype=int), np.empty(0, dtype=bool),
                   np.empty(0), np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))

    @classmethod
    def concatenate(cls, parts: list[Clusters]) -> Clusters:
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in cls._FIELDS))

    def __len__(self) -> int:
        return len(self.radius)

    def select(self, mask: np.ndarray) -> Clusters:
        return Clusters(*(getattr(self, name)[mask] for name in self._FIELDS))


def segment(scan: Scan, breakpoint_angle: float, breakpoint_distance: float, range_noise: float,
            min_points: int, structure: np.ndarray | None = None, first_beam: int = 0) -> Clusters:
    """The clusters of one scan with at least min_points returns; structure: per beam, whether its return lies
    on structure (none: no return does); first_beam: the number of the scan's first beam in Clusters.first/last."""
    beams = np.flatnonzero(scan.valid())
    if len(beams) < max(min_points, 1):
        return Clusters.empty()
    r = scan.ranges[beams]
    a = scan.angles[beams]
    step = np.abs(np.diff(a))
    cos_a, sin_a = np.cos(a), np.sin(a)
    gap = np.hypot(np.diff(r * cos_a), np.diff(r * sin_a))
    with np.errstate(divide="ignore", invalid="ignore"):
        limit = np.minimum(r[:-1], r[1:]) * np.sin(step) / np.sin(np.maximum(breakpoint_angle - step, 1e-6))
    limit = np.maximum(limit + 3.0 * range_noise, breakpoint_distance)
    broken = (gap > limit) | (np.diff(beams) > MAX_MISSING_BEAMS + 1)
    starts = np.concatenate([[0], np.flatnonzero(broken) + 1])
    ends = np.concatenate([starts[1:], [len(beams)]]) - 1           # inclusive
    counts = ends - starts + 1
    beam_step = abs(float(scan.angles[1] - scan.angles[0])) if len(scan.angles) > 1 else 0.0
    centre, radius = _circles(scan.origin, r, a, starts, ends, counts, beam_step)
    keep = counts >= min_points
    occluded = _occluded_ends(scan, beams, r, starts[keep], ends[keep])
    on_structure = np.zeros(len(beams)) if structure is None else structure[beams].astype(float)
    share = np.add.reduceat(on_structure, starts) / counts
    return Clusters(centre[keep], radius[keep], 2.0 * radius[keep], counts[keep], occluded, share[keep],
                    first_beam + beams[starts[keep]], first_beam + beams[ends[keep]])


def _circles(origin, r, a, starts, ends, counts, beam_step: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre and radius of the circle each cluster (returns starts[k]..ends[k]) is the near side of.

    A circle of radius R at distance d fills the bearings between its two tangents, half-angle beta with
    sin(beta) = R / d, and the tangent points lie at L = d cos(beta): so R = L tan(beta). The true tangents lie
    up to one beam beyond the outer returns, hence half a beam more on each side. The outer returns lie a little
    inside the tangents, so d comes from every return instead: one at range r, phi off the centre's bearing,
    lies on the circle when d = r cos(phi) + sqrt(R^2 - r^2 sin^2(phi)); d is their mean."""
    half_angle = np.minimum(0.5 * (np.abs(a[ends] - a[starts]) + beam_step), 1.4)
    radius = 0.5 * (r[starts] + r[ends]) * np.tan(half_angle)
    bearing = 0.5 * (a[starts] + a[ends])
    phi = a - np.repeat(bearing, counts)
    across = r * np.sin(phi)
    depth = r * np.cos(phi) + np.sqrt(np.maximum(np.repeat(radius, counts) ** 2 - across ** 2, 0.0))
    distance = np.add.reduceat(depth, starts) / counts
    centre = origin + distance[:, None] * np.stack([np.cos(bearing), np.sin(bearing)], axis=1)
    return centre, radius


def _occluded_ends(scan: Scan, beams: np.ndarray, r: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Clusters whose outline is cut at either end: by a nearer neighbour, the scan's edge or the range limit."""
    last = len(scan.ranges) - 1
    cut = (beams[starts] == 0) | (beams[ends] == last)
    near_limit = scan.range_max - RANGE_LIMIT_MARGIN
    cut |= (r[starts] > near_limit) | (r[ends] > near_limit)
    before = starts - 1
    has_before = before >= 0
    cut[has_before] |= (r[before[has_before]] < r[starts[has_before]]) & \
        (beams[starts[has_before]] - beams[before[has_before]] <= 2)
    after = ends + 1
    has_after = after < len(beams)
    cut[has_after] |= (r[after[has_after]] < r[ends[has_after]]) & \
        (beams[after[has_after]] - beams[ends[has_after]] <= 2)
    return cut


def fit_known_circles(points: np.ndarray, first: np.ndarray, last: np.ndarray, radius: np.ndarray,
                      start: np.ndarray, range_noise: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres (K, 2) of circles of known radius (K,) through the returns points[first[k]..last[k]] (NaN rows:
    no return), by Gauss-Newton from `start` (K, 2); their covariances (K, 2, 2) for returns of range_noise, and
    the RMS distance (K,) of the returns from each circle. A short arc fixes the centre along the line of sight
    and little across it: the covariance says so."""
    counts = last - first + 1
    group = np.repeat(np.arange(len(first)), counts)
    index = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + np.repeat(first, counts)
    xy = points[index]
    ok = np.isfinite(xy[:, 0])
    xy, group = xy[ok], group[ok]
    centre = np.array(start, dtype=float)
    k = len(first)
    for _ in range(FIT_ITERATIONS):
        d = xy - centre[group]
        n = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        u = d / n[:, None]
        residual = n - radius[group]
        a = np.stack([np.bincount(group, u[:, 0] * u[:, 0], k), np.bincount(group, u[:, 0] * u[:, 1], k),
                      np.bincount(group, u[:, 1] * u[:, 1], k)], axis=1) + 1e-9
        b = np.stack([np.bincount(group, u[:, 0] * residual, k), np.bincount(group, u[:, 1] * residual, k)], axis=1)
        # damped normal equations (J^T J + FIT_DAMPING) step = -J^T r with J = -u: the centre moves along +u
        # times the residual; the damping keeps a short arc's weak direction near the start
        d0, d2 = a[:, 0] + FIT_DAMPING, a[:, 2] + FIT_DAMPING
        step_det = d0 * d2 - a[:, 1] ** 2
        centre += np.column_stack([d2 * b[:, 0] - a[:, 1] * b[:, 1], d0 * b[:, 1] - a[:, 1] * b[:, 0]]) / \
            step_det[:, None]
    det = a[:, 0] * a[:, 2] - a[:, 1] ** 2
    d = xy - centre[group]
    residual = np.hypot(d[:, 0], d[:, 1]) - radius[group]
    rms = np.sqrt(np.bincount(group, residual ** 2, k) / np.maximum(np.bincount(group, minlength=k), 1))
    cov = np.stack([np.stack([a[:, 2], -a[:, 1]], -1), np.stack([-a[:, 1], a[:, 0]], -1)], -2) / det[:, None, None]
    return centre, cov * range_noise ** 2, rms
