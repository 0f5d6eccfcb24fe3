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

from simplebot_navigation.perception.tracking_kernels import continues_straight, segment_scan

#: a cluster end within this of range_max is cut by the range limit
#: beams without a return a cluster may span (more: a gap beyond the range limit lies between)
MAX_MISSING_BEAMS = 1
RANGE_LIMIT_MARGIN = 0.3
#: a cluster end this close to the neighbouring return, where the returns on both sides go on along one line,
#: is a surface broken up, not an object's outline: straight within JOINED_TOLERANCE over JOINED_SPAN either side
#: (a person's arc bulges 0.04 m and more over 0.3 m; two people touching meet at an angle)
JOINED_GAP = 0.25
JOINED_SPAN = 0.3
JOINED_TOLERANCE = 0.03
#: a round outline seen whole lies within one radius from its nearest return to its farthest; a whole cluster
#: deeper than ROUND_DEPTH radii (and 3 sigma of range noise) is a surface seen at a grazing angle, whose pieces
#: slide along it as the sensor moves (a cut arc's radius, from its angular width, is too small for this test)
ROUND_DEPTH = 1.5
#: Gauss-Newton steps of the known-radius circle fit
FIT_ITERATIONS = 5
#: Levenberg damping of the fit's steps, in returns' worth of information in every direction
FIT_DAMPING = 0.5
#: information on a known radius: it stays as given
FIXED_INFORMATION = 1e12


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

    def shows_gone(self, centres: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Whether this scan shows each object (centres (M, 2), radius (M,)) gone: within its field of view and range, the beam towards its centre
        passes the centre (not stopped by something nearer, by the object itself or by something touching it, nor
        lost)."""
        step = self.angles[1] - self.angles[0] if len(self.angles) > 1 else 0.0
        if not step or not len(centres):
            return np.zeros(len(centres), dtype=bool)
        offset = centres - self.origin
        distance = np.hypot(offset[:, 0], offset[:, 1])
        bearing = np.arctan2(offset[:, 1], offset[:, 0])
        span = ((bearing - self.angles[0]) * np.sign(step)) % (2 * np.pi)
        index = np.round(span / abs(step)).astype(np.int64)
        inside = (index >= 0) & (index < len(self.angles)) & (distance + radius < self.range_max) & \
            (distance - radius > self.range_min)
        with np.errstate(invalid="ignore"):
            beyond = self.ranges >= self.range_max                  # +inf too: nothing there
        reach = np.where(self.valid(), self.ranges, np.where(beyond, np.inf, -np.inf))   # NaN: no information
        beam = np.clip(index, 0, len(self.angles) - 1)
        return inside & (reach[beam] >= distance)

    def valid(self) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return np.isfinite(self.ranges) & (self.ranges >= max(self.range_min, 0.0)) & \
                (self.ranges < self.range_max)


@dataclass
class Clusters:
    """K clusters: centre (K, 2), radius (K,), width (K,), count (K,), occluded (K,), structure (K,): the
    share of each cluster's returns that lie on structure (StructureMap), and first, last (K,): the beams of its
    outer returns (numbered on from `first_beam` of segment(), so that clusters of several scans index their
    concatenated points), unfit (K,): no object's whole outline: cut by the range limit and straight (what lies
    beyond is unknown), joined to a neighbouring return (a surface broken up) or, seen whole, deeper than round (a
    surface at a grazing angle); range_cut (K,): occluded by the range limit alone (its cut moves along the line of
    sight, not across it as one by something nearer or by the field's edge does)."""
    centre: np.ndarray
    radius: np.ndarray
    width: np.ndarray
    count: np.ndarray
    occluded: np.ndarray
    structure: np.ndarray
    first: np.ndarray
    last: np.ndarray
    unfit: np.ndarray
    range_cut: np.ndarray

    _FIELDS = ("centre", "radius", "width", "count", "occluded", "structure", "first", "last", "unfit", "range_cut")

    @classmethod
    def empty(cls) -> Clusters:
        return cls(np.empty((0, 2)), np.empty(0), np.empty(0), np.empty(0, dtype=int), np.empty(0, dtype=bool),
                   np.empty(0), np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64), np.empty(0, dtype=bool),
                   np.empty(0, dtype=bool))

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
    on structure (none: no return does); first_beam: the number of the scan's first beam in Clusters.first/last.
    Compiled (tracking_kernels.segment_scan); segment_reference is the same in array form."""
    valid = scan.valid()
    if valid.sum() < max(min_points, 1):
        return Clusters.empty()
    on_structure = np.zeros(len(valid)) if structure is None else np.asarray(structure, dtype=float)
    centre, radius, count, occluded, share, first, last, unfit, range_cut = segment_scan(
        np.asarray(scan.ranges, dtype=float), np.asarray(scan.angles, dtype=float), valid, on_structure,
        np.asarray(scan.origin, dtype=float), float(breakpoint_angle), float(breakpoint_distance),
        float(range_noise), int(min_points), float(scan.range_max), MAX_MISSING_BEAMS, RANGE_LIMIT_MARGIN,
        JOINED_GAP, JOINED_SPAN, JOINED_TOLERANCE, ROUND_DEPTH)
    return Clusters(centre, radius, 2.0 * radius, count, occluded, share, first_beam + first, first_beam + last,
                    unfit, range_cut)


def segment_reference(scan: Scan, breakpoint_angle: float, breakpoint_distance: float, range_noise: float,
                      min_points: int, structure: np.ndarray | None = None, first_beam: int = 0) -> Clusters:
    """segment() in array form, the reference its compiled kernel is tested against."""
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
    occluded, far, joined = _occluded_ends(scan, beams, r, starts[keep], ends[keep])
    range_cut = far & ~_cut_across(scan, beams, r, starts[keep], ends[keep])
    cut_far = np.flatnonzero(far)
    far[cut_far] = _straight(r[:, None] * np.column_stack([cos_a, sin_a]), starts[keep][cut_far], ends[keep][cut_far])
    on_structure = np.zeros(len(beams)) if structure is None else structure[beams].astype(float)
    share = np.add.reduceat(on_structure, starts) / counts
    deep = np.maximum.reduceat(r, starts) - np.minimum.reduceat(r, starts) > ROUND_DEPTH * radius + 3.0 * range_noise
    return Clusters(centre[keep], radius[keep], 2.0 * radius[keep], counts[keep], occluded, share[keep],
                    first_beam + beams[starts[keep]], first_beam + beams[ends[keep]], far | joined | (deep[keep] & ~occluded),
                    range_cut)


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


def _straight(xy: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """(K,) whether every return of cluster k (xy[starts[k]..ends[k]]) lies within JOINED_TOLERANCE of the line
    through its first and last."""
    chord = xy[ends] - xy[starts]
    normal = np.column_stack([-chord[:, 1], chord[:, 0]]) / np.maximum(np.hypot(*chord.T), 1e-9)[:, None]
    counts = ends - starts + 1
    member = np.repeat(np.arange(len(starts)), counts)
    index = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + np.repeat(starts, counts)
    bulge = np.zeros(len(starts))
    np.maximum.at(bulge, member, np.abs(np.einsum("ki,ki->k", xy[index] - xy[starts[member]], normal[member])))
    return bulge <= JOINED_TOLERANCE


def _occluded_ends(scan: Scan, beams: np.ndarray, r: np.ndarray, starts: np.ndarray,
                   ends: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cut, far, joined) per cluster: its outline is cut at either end by a nearer neighbour, the scan's edge or
    the range limit; cut by the range limit; joined to a neighbouring return less than JOINED_GAP away by a
    straight surface (one broken up at a grazing angle: its pieces slide along it as the sensor moves)."""
    near_limit = scan.range_max - RANGE_LIMIT_MARGIN
    far = (r[starts] > near_limit) | (r[ends] > near_limit)
    cut = far | _cut_across(scan, beams, r, starts, ends)
    joined = np.zeros(len(starts), dtype=bool)
    a = scan.angles[beams]
    xy = r[:, None] * np.column_stack([np.cos(a), np.sin(a)])
    for end, neighbour in ((starts, starts - 1), (ends, ends + 1)):
        has = (neighbour >= 0) & (neighbour < len(beams))
        e, n = end[has], neighbour[has]
        adjacent = np.abs(beams[e] - beams[n]) <= 2
        close = adjacent & (np.hypot(*(xy[e] - xy[n]).T) < JOINED_GAP)
        k = np.flatnonzero(has)[close]
        joined[k] |= continues_straight(xy, e[close], n[close] - e[close], starts[k], ends[k], JOINED_SPAN,
                                        JOINED_GAP, JOINED_TOLERANCE)
    return cut, far, joined


def _cut_across(scan: Scan, beams: np.ndarray, r: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """(K,) whether cluster k's outline is cut by a nearer neighbouring return or by the scan's first or last beam."""
    cut = (beams[starts] == 0) | (beams[ends] == len(scan.ranges) - 1)
    for end, neighbour in ((starts, starts - 1), (ends, ends + 1)):
        has = (neighbour >= 0) & (neighbour < len(beams))
        e, n = end[has], neighbour[has]
        cut[has] |= (r[n] < r[e]) & (np.abs(beams[e] - beams[n]) <= 2)
    return cut


def fit_circles(points: np.ndarray, first: np.ndarray, last: np.ndarray, radius: np.ndarray, known: np.ndarray,
                start: np.ndarray, range_noise: float) -> tuple[np.ndarray, ...]:
    """Circles through the returns points[first[k]..last[k]] (NaN rows: no return) by damped Gauss-Newton from
    centres `start` (K, 2) and radii `radius` (K,), which stay where `known` (K,) and are fitted too elsewhere.
    Returns centres (K, 2), their covariances (K, 2, 2) for returns of range_noise (a fitted radius's
    uncertainty included), radii (K,), the radii's sigmas (K,; 0 where known) and the RMS distance (K,) of the
    returns from each circle. A short arc fixes the centre along the line of sight and little across it, and
    a fitted radius hardly at all: the covariances say so."""
    counts = last - first + 1
    group = np.repeat(np.arange(len(first)), counts)
    index = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + np.repeat(first, counts)
    xy = points[index]
    ok = np.isfinite(xy[:, 0])
    xy, group = xy[ok], group[ok]
    k = len(first)
    centre, radius = np.array(start, dtype=float), np.array(radius, dtype=float)
    fixed = np.where(known, FIXED_INFORMATION, 0.0)
    for _ in range(FIT_ITERATIONS):
        u, residual = _unit_and_residual(xy, group, centre, radius)
        # J = -(ux, uy, 1) per return: (J^T J + damping) step = -J^T r
        normal = _normal_matrix(u, group, k)
        normal += np.eye(3) * FIT_DAMPING
        normal[:, 2, 2] += fixed
        rhs = np.stack([np.bincount(group, u[:, 0] * residual, k), np.bincount(group, u[:, 1] * residual, k),
                        np.bincount(group, residual, k)], axis=1)
        step = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
        centre += step[:, :2]
        radius += step[:, 2]
    u, residual = _unit_and_residual(xy, group, centre, radius)
    normal = _normal_matrix(u, group, k) + np.eye(3) * 1e-9
    normal[:, 2, 2] += fixed
    cov = np.linalg.inv(normal) * range_noise ** 2
    rms = np.sqrt(np.bincount(group, residual ** 2, k) / np.maximum(np.bincount(group, minlength=k), 1))
    return centre, cov[:, :2, :2], radius, np.sqrt(np.where(known, 0.0, cov[:, 2, 2])), rms


def _unit_and_residual(xy, group, centre, radius):
    d = xy - centre[group]
    n = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
    return d / n[:, None], n - radius[group]


def _normal_matrix(u, group, k) -> np.ndarray:
    """(K, 3, 3) sums of J^T J over each circle's returns, J = -(ux, uy, 1)."""
    columns = (u[:, 0], u[:, 1], np.ones(len(u)))
    out = np.empty((k, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            out[:, i, j] = out[:, j, i] = np.bincount(group, columns[i] * columns[j], k)
    return out
