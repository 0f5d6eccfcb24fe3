"""Compiled kernels of the tracker's many small per-track and per-cluster steps (docs/reference.md §6).

Why numba: a scan pair meets a few dozen clusters and tracks, each needing a 3x3 or 4x4 solve; the array
forms of these steps (segmentation.fit_circles, kalman.predict / update / combine, which stay as the
reference the tests hold these to) spend their time in numpy's per-call overhead, not in arithmetic. Loops
over the tracks compiled with ``cache=True`` do the same work in a few microseconds; warm_up() in tracker.py
loads them before the first scan.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def _solve3(a, b):
    """x with a x = b for a symmetric positive definite 3x3 a (Cholesky)."""
    l00 = np.sqrt(a[0, 0])
    l10 = a[1, 0] / l00
    l20 = a[2, 0] / l00
    l11 = np.sqrt(a[1, 1] - l10 * l10)
    l21 = (a[2, 1] - l20 * l10) / l11
    l22 = np.sqrt(a[2, 2] - l20 * l20 - l21 * l21)
    y0 = b[0] / l00
    y1 = (b[1] - l10 * y0) / l11
    y2 = (b[2] - l20 * y0 - l21 * y1) / l22
    x2 = y2 / l22
    x1 = (y1 - l21 * x2) / l11
    x0 = (y0 - l10 * x1 - l20 * x2) / l00
    return x0, x1, x2


@njit(cache=True, nogil=True, error_model="numpy")
def _normal_equations(points, first, last, cx, cy, r, normal, rhs):
    """Sums of J^T J and J^T residual over one circle's returns (J = -(ux, uy, 1)); returns sum of residual^2
    and the number of returns."""
    normal[:] = 0.0
    rhs[:] = 0.0
    squares = 0.0
    n = 0
    for i in range(first, last + 1):
        dx = points[i, 0] - cx
        dy = points[i, 1] - cy
        if not (np.isfinite(dx) and np.isfinite(dy)):
            continue
        d = max(np.hypot(dx, dy), 1e-9)
        u = (dx / d, dy / d, 1.0)
        res = d - r
        for a in range(3):
            rhs[a] += u[a] * res
            for b in range(3):
                normal[a, b] += u[a] * u[b]
        squares += res * res
        n += 1
    return squares, n


@njit(cache=True, nogil=True, error_model="numpy")
def fit_circles(points, first, last, radius, known, start, range_noise, iterations, damping, fixed_information):
    """segmentation.fit_circles compiled: the same damped Gauss-Newton steps and outputs."""
    k = len(first)
    centre = start.astype(np.float64).copy()
    radius = radius.astype(np.float64).copy()
    cov = np.empty((k, 2, 2))
    sigma = np.zeros(k)
    rms = np.empty(k)
    normal = np.empty((3, 3))
    rhs = np.empty(3)
    for c in range(k):
        fixed = fixed_information if known[c] else 0.0
        for _ in range(iterations):
            _normal_equations(points, first[c], last[c], centre[c, 0], centre[c, 1], radius[c], normal, rhs)
            for a in range(3):
                normal[a, a] += damping
            normal[2, 2] += fixed
            s0, s1, s2 = _solve3(normal, rhs)
            centre[c, 0] += s0
            centre[c, 1] += s1
            radius[c] += s2
        squares, n = _normal_equations(points, first[c], last[c], centre[c, 0], centre[c, 1], radius[c], normal,
                                       rhs)
        for a in range(3):
            normal[a, a] += 1e-9
        normal[2, 2] += fixed
        inverse = np.linalg.inv(normal) * range_noise ** 2
        cov[c] = inverse[:2, :2]
        if not known[c]:
            sigma[c] = np.sqrt(inverse[2, 2])
        rms[c] = np.sqrt(squares / max(n, 1))
    return centre, cov, radius, sigma, rms


@njit(cache=True, nogil=True, error_model="numpy")
def imm_predict(states, covs, probs, switch, f, q):
    """kalman.predict compiled, given the (M, M) switching matrix and each model's (M, 4, 4) transition f and
    process noise q; in place."""
    t_count, m_count = probs.shape
    mixed = np.empty((m_count, 4))
    mixed_cov = np.empty((m_count, 4, 4))
    predicted = np.empty(m_count)
    for t in range(t_count):
        for j in range(m_count):
            total = 0.0
            for i in range(m_count):
                total += probs[t, i] * switch[i, j]
            predicted[j] = total
        for j in range(m_count):
            norm = max(predicted[j], 1e-300)
            mixed[j] = 0.0
            for i in range(m_count):
                mixed[j] += probs[t, i] * switch[i, j] / norm * states[t, i]
            mixed_cov[j] = 0.0
            for i in range(m_count):
                w = probs[t, i] * switch[i, j] / norm
                d = states[t, i] - mixed[j]
                for a in range(4):
                    for b in range(4):
                        mixed_cov[j, a, b] += w * (covs[t, i, a, b] + d[a] * d[b])
        for j in range(m_count):
            states[t, j] = f[j] @ mixed[j]
            covs[t, j] = f[j] @ mixed_cov[j] @ f[j].T + q[j]
            probs[t, j] = predicted[j]


@njit(cache=True, nogil=True, error_model="numpy")
def imm_update(states, covs, probs, measured, noise):
    """kalman.update compiled: position measurements (T, 2) with covariances (T, 2, 2); in place."""
    t_count, m_count = probs.shape
    log_likelihood = np.empty(m_count)
    gain = np.empty((4, 2))
    for t in range(t_count):
        for m in range(m_count):
            s00 = covs[t, m, 0, 0] + noise[t, 0, 0]
            s01 = covs[t, m, 0, 1] + noise[t, 0, 1]
            s10 = covs[t, m, 1, 0] + noise[t, 1, 0]
            s11 = covs[t, m, 1, 1] + noise[t, 1, 1]
            det = s00 * s11 - s01 * s10
            i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
            e0 = measured[t, 0] - states[t, m, 0]
            e1 = measured[t, 1] - states[t, m, 1]
            for a in range(4):
                gain[a, 0] = covs[t, m, a, 0] * i00 + covs[t, m, a, 1] * i10
                gain[a, 1] = covs[t, m, a, 0] * i01 + covs[t, m, a, 1] * i11
            for a in range(4):
                states[t, m, a] += gain[a, 0] * e0 + gain[a, 1] * e1
            top = covs[t, m, :2, :].copy()
            for a in range(4):
                for b in range(4):
                    covs[t, m, a, b] -= gain[a, 0] * top[0, b] + gain[a, 1] * top[1, b]
            for a in range(4):
                for b in range(a + 1, 4):
                    mean = 0.5 * (covs[t, m, a, b] + covs[t, m, b, a])
                    covs[t, m, a, b] = mean
                    covs[t, m, b, a] = mean
            mahalanobis = e0 * (i00 * e0 + i01 * e1) + e1 * (i10 * e0 + i11 * e1)
            log_likelihood[m] = -0.5 * mahalanobis - 0.5 * np.log(det)
        best = log_likelihood.max()
        total = 0.0
        for m in range(m_count):
            probs[t, m] *= np.exp(log_likelihood[m] - best)
            total += probs[t, m]
        total = max(total, 1e-300)
        for m in range(m_count):
            probs[t, m] /= total


@njit(cache=True, nogil=True, error_model="numpy")
def imm_combine(states, covs, probs):
    """kalman.combine compiled: one (T, 4) state and (T, 4, 4) covariance per track."""
    t_count, m_count = probs.shape
    state = np.zeros((t_count, 4))
    cov = np.zeros((t_count, 4, 4))
    for t in range(t_count):
        for m in range(m_count):
            state[t] += probs[t, m] * states[t, m]
        for m in range(m_count):
            d = states[t, m] - state[t]
            for a in range(4):
                for b in range(4):
                    cov[t, a, b] += probs[t, m] * (covs[t, m, a, b] + d[a] * d[b])
    return state, cov


@njit(cache=True, nogil=True, inline="always")
def _distance(xy, i, j):
    return np.hypot(xy[i, 0] - xy[j, 0], xy[i, 1] - xy[j, 1])


@njit(cache=True, nogil=True, error_model="numpy")
def continues_straight(xy, ends, directions, lows, highs, span, max_gap, tolerance):
    """For each cluster end xy[ends[k]] and the returns beyond it (directions[k]: +1 or -1): whether the returns
    within `span` of it on both sides (two at least on each), the cluster's own (indices lows[k]..highs[k]) and
    those beyond (each less than max_gap from the one before), lie within `tolerance` of the line through the
    outermost of them: a surface going on straight through the break. Fewer than two returns on a side cannot
    show one."""
    out = np.ones(len(ends), dtype=np.bool_)
    for k in range(len(ends)):
        e, d = ends[k], directions[k]
        inner = e
        while lows[k] <= inner - d <= highs[k] and (inner == e or _distance(xy, inner - d, e) <= span):
            inner -= d
        outer = e + d
        while 0 <= outer + d < len(xy) and (outer == e + d or _distance(xy, outer + d, e) <= span) and \
                _distance(xy, outer + d, outer) < max_gap:
            outer += d
        if inner == e or outer == e + d:
            out[k] = False
            continue
        a, b = xy[inner], xy[outer]
        length = max(np.hypot(b[0] - a[0], b[1] - a[1]), 1e-9)
        nx, ny = -(b[1] - a[1]) / length, (b[0] - a[0]) / length
        i = inner
        while i != outer:
            if abs((xy[i, 0] - a[0]) * nx + (xy[i, 1] - a[1]) * ny) > tolerance:
                out[k] = False
                break
            i += d
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _bulge(xy, start, end):
    """The largest distance of the returns xy[start..end] from the line through the first and the last."""
    dx, dy = xy[end, 0] - xy[start, 0], xy[end, 1] - xy[start, 1]
    length = max(np.hypot(dx, dy), 1e-9)
    worst = 0.0
    for i in range(start, end + 1):
        worst = max(worst, abs((xy[i, 0] - xy[start, 0]) * -dy + (xy[i, 1] - xy[start, 1]) * dx) / length)
    return worst


@njit(cache=True, nogil=True, error_model="numpy")
def segment_scan(ranges, angles, valid, structure, origin, breakpoint_angle, breakpoint_distance, range_noise,
                 min_points, range_max, max_missing_beams, range_limit_margin, joined_gap, joined_span,
                 joined_tolerance, round_depth):
    """segmentation.segment_reference compiled: (centre, radius, count, occluded, structure share, first beam,
    last beam, unfit, range_cut) of the clusters of one scan with at least min_points returns."""
    beams = np.flatnonzero(valid)
    n = len(beams)
    r, a = ranges[beams], angles[beams]
    xy = np.empty((n, 2))
    xy[:, 0], xy[:, 1] = r * np.cos(a), r * np.sin(a)
    starts = np.empty(n, dtype=np.int64)
    k = 0
    for i in range(n):
        if i == 0:
            starts[k], k = 0, k + 1
            continue
        step = abs(a[i] - a[i - 1])
        limit = min(r[i - 1], r[i]) * np.sin(step) / np.sin(max(breakpoint_angle - step, 1e-6))
        limit = max(limit + 3.0 * range_noise, breakpoint_distance)
        if np.hypot(xy[i, 0] - xy[i - 1, 0], xy[i, 1] - xy[i - 1, 1]) > limit or \
                beams[i] - beams[i - 1] > max_missing_beams + 1:
            starts[k], k = i, k + 1
    starts = starts[:k]
    ends = np.empty(k, dtype=np.int64)
    ends[:k - 1] = starts[1:] - 1
    ends[k - 1] = n - 1
    keep = np.flatnonzero(ends - starts + 1 >= min_points)
    m = len(keep)
    centre, radius, count = np.empty((m, 2)), np.empty(m), np.empty(m, dtype=np.int64)
    occluded, share, unfit = np.zeros(m, dtype=np.bool_), np.empty(m), np.zeros(m, dtype=np.bool_)
    range_cut = np.zeros(m, dtype=np.bool_)
    beam_step = abs(angles[1] - angles[0]) if len(angles) > 1 else 0.0
    near_limit = range_max - range_limit_margin
    for c in range(m):
        s, e = starts[keep[c]], ends[keep[c]]
        count[c] = e - s + 1
        half_angle = min(0.5 * (abs(a[e] - a[s]) + beam_step), 1.4)
        radius[c] = 0.5 * (r[s] + r[e]) * np.tan(half_angle)
        bearing = 0.5 * (a[s] + a[e])
        depth, hits, nearest, farthest = 0.0, 0.0, r[s], r[s]
        for i in range(s, e + 1):
            nearest, farthest = min(nearest, r[i]), max(farthest, r[i])
            phi = a[i] - bearing
            across = r[i] * np.sin(phi)
            depth += r[i] * np.cos(phi) + np.sqrt(max(radius[c] ** 2 - across ** 2, 0.0))
            hits += structure[beams[i]]
        depth /= count[c]
        share[c] = hits / count[c]
        centre[c, 0], centre[c, 1] = origin[0] + depth * np.cos(bearing), origin[1] + depth * np.sin(bearing)
        occluded[c] = beams[s] == 0 or beams[e] == len(ranges) - 1
        far = r[s] > near_limit or r[e] > near_limit
        joined = False
        for end, d in ((s, -1), (e, 1)):
            nb = end + d
            if nb < 0 or nb >= n or abs(beams[end] - beams[nb]) > 2:
                continue
            occluded[c] |= r[nb] < r[end]
            if np.hypot(xy[end, 0] - xy[nb, 0], xy[end, 1] - xy[nb, 1]) < joined_gap:
                one = np.array([end])
                joined |= continues_straight(xy, one, np.array([d]), np.array([s]), np.array([e]), joined_span,
                                             joined_gap, joined_tolerance)[0]
        range_cut[c] = far and not occluded[c]
        occluded[c] |= far
        unfit[c] = joined or (far and _bulge(xy, s, e) <= joined_tolerance) or \
            (not occluded[c] and farthest - nearest > round_depth * radius[c] + 3.0 * range_noise)
    return centre, radius, count, occluded, share, beams[starts[keep]], beams[ends[keep]], unfit, range_cut


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel now, with the argument types the tracker passes: the first
    scans otherwise wait for it."""
    states, covs, probs = np.zeros((1, 3, 4)), np.tile(np.eye(4), (1, 3, 1, 1)), np.full((1, 3), 1.0 / 3.0)
    imm_predict(states, covs, probs, np.eye(3), np.tile(np.eye(4), (3, 1, 1)), np.zeros((3, 4, 4)))
    imm_update(states, covs, probs, np.zeros((1, 2)), np.tile(np.eye(2), (1, 1, 1)))
    imm_combine(states, covs, probs)
    arc = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    fit_circles(arc, np.zeros(1, dtype=np.int64), np.full(1, 2, dtype=np.int64), np.ones(1), np.ones(1, dtype=bool),
                np.zeros((1, 2)), 0.01, 1, 0.5, 1e12)
    ranges, angles = np.full(8, 1.0), np.linspace(-0.4, 0.4, 8)
    segment_scan(ranges, angles, np.ones(8, dtype=np.bool_), np.zeros(8), np.zeros(2), 0.17, 0.05, 0.01, 3, 5.6, 1,
                 0.3, 0.25, 0.3, 0.03, 1.5)
