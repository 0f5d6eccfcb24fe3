"""Compiled loops of the correlative scan matcher (scan_matcher.py).

A match scores tens of thousands of candidate poses against a few hundred returns each, and the branch-and-bound
search behind it pops and pushes nodes one at a time: in numpy every node would cost a handful of temporaries, so
the search, the likelihood field's construction and the sub-cell refinement are loops compiled by numba
(``cache=True``, GIL released).

Grids are in nav_msgs/OccupancyGrid order (rows = y). ``cells[a, p]`` is the (row, col) return p falls in at the
search's a-th heading and offset (0, 0); a candidate (a, row, col) moves every return by (row, col) cells.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: the splat stops at this many deviations, where the Gaussian is ~1 % of its peak
SMEAR_REACH = 3.0


@njit(cache=True, nogil=True)
def splat_likelihood(out, origin_x, origin_y, resolution, points, deviation):
    """Raise each cell of ``out`` to the Gaussian of its centre's distance to ``points`` (the likelihood field of
    Thrun's beam model), so the field peaks where the walls really are, not at the centres of their cells."""
    rows, cols = out.shape
    reach = SMEAR_REACH * deviation
    scale = -0.5 / (deviation * deviation)
    for i in range(points.shape[0]):
        px, py = points[i, 0], points[i, 1]
        r0 = max(int(math.floor((py - reach - origin_y) / resolution)), 0)
        r1 = min(int(math.floor((py + reach - origin_y) / resolution)) + 1, rows)
        c0 = max(int(math.floor((px - reach - origin_x) / resolution)), 0)
        c1 = min(int(math.floor((px + reach - origin_x) / resolution)) + 1, cols)
        for row in range(r0, r1):
            dy = origin_y + (row + 0.5) * resolution - py
            for col in range(c0, c1):
                dx = origin_x + (col + 0.5) * resolution - px
                d2 = dx * dx + dy * dy
                if d2 <= reach * reach:
                    value = math.exp(scale * d2)
                    if value > out[row, col]:
                        out[row, col] = value


@njit(cache=True, nogil=True)
def node_score(levels, depth, cells, a, row, col):
    """The sum over the returns of ``levels[depth]`` at their cells moved by (row, col): with levels[depth] the
    maximum over 2**depth x 2**depth cells, an upper bound of every candidate of the node; at depth 0 its score.
    A window reaching into the grid from below or left is bounded by the grid's first window."""
    _, rows, cols = levels.shape
    span = 1 << depth
    total = 0.0
    for p in range(cells.shape[1]):
        r = cells[a, p, 0] + row
        c = cells[a, p, 1] + col
        if r >= rows or c >= cols or r <= -span or c <= -span:
            continue
        total += levels[depth, max(r, 0), max(c, 0)]
    return total


@njit(cache=True, nogil=True)
def _before(keys, nodes, i, j):
    """Heap order: the higher bound first; on a tie the shallower node, so an exact leaf ends a plateau."""
    return keys[i] > keys[j] or (keys[i] == keys[j] and nodes[i, 1] < nodes[j, 1])


@njit(cache=True, nogil=True)
def _swap(keys, nodes, i, j):
    keys[i], keys[j] = keys[j], keys[i]
    for k in range(4):
        nodes[i, k], nodes[j, k] = nodes[j, k], nodes[i, k]


@njit(cache=True, nogil=True)
def _push(keys, nodes, size, key, a, depth, row, col):
    """Add a node to the max-heap, doubling its arrays when full; returns the (maybe new) arrays and size."""
    if size == keys.shape[0]:
        grown_keys = np.empty(2 * size)
        grown_nodes = np.empty((2 * size, 4), np.int64)
        grown_keys[:size] = keys
        grown_nodes[:size] = nodes
        keys, nodes = grown_keys, grown_nodes
    keys[size] = key
    nodes[size, 0], nodes[size, 1], nodes[size, 2], nodes[size, 3] = a, depth, row, col
    i = size
    while i > 0 and _before(keys, nodes, i, (i - 1) // 2):
        _swap(keys, nodes, i, (i - 1) // 2)
        i = (i - 1) // 2
    return keys, nodes, size + 1


@njit(cache=True, nogil=True)
def _pop(keys, nodes, size):
    """Remove the heap's best node; returns its key, a, depth, row, col."""
    key, a, depth, row, col = keys[0], nodes[0, 0], nodes[0, 1], nodes[0, 2], nodes[0, 3]
    size -= 1
    _swap(keys, nodes, 0, size)
    i = 0
    while True:
        best, left, right = i, 2 * i + 1, 2 * i + 2
        if left < size and _before(keys, nodes, left, best):
            best = left
        if right < size and _before(keys, nodes, right, best):
            best = right
        if best == i:
            return key, a, depth, row, col
        _swap(keys, nodes, i, best)
        i = best


@njit(cache=True, nogil=True)
def _excluded(found, n, angles, a, depth, row, col, separation, angle_separation):
    """Whether every candidate of the node lies within ``separation`` cells and ``angle_separation`` of a pose
    already found: such a node can only repeat that pose."""
    if separation <= 0.0:
        return False
    last = (1 << depth) - 1
    for k in range(n):
        dr = max(abs(row - found[k, 1]), abs(row + last - found[k, 1]))
        dc = max(abs(col - found[k, 2]), abs(col + last - found[k, 2]))
        if dr * dr + dc * dc >= separation * separation:
            continue
        if abs((angles[a] - angles[found[k, 0]] + math.pi) % (2.0 * math.pi) - math.pi) < angle_separation:
            return True
    return False


@njit(cache=True, nogil=True)
def _distance_penalty(row, col, span, gain, minimum):
    """The largest distance penalty over the offsets [row, row + span) x [col, col + span)."""
    dr = 0 if row <= 0 < row + span else min(abs(row), abs(row + span - 1))
    dc = 0 if col <= 0 < col + span else min(abs(col), abs(col + span - 1))
    return max(1.0 - gain * (dr * dr + dc * dc), minimum)


@njit(cache=True, nogil=True)
def best_first(levels, allowed, cells, window, root_depth, count, angles, separation, angle_separation,
               angle_penalty, distance_gain, minimum_distance_penalty):
    """Branch and bound (Olson 2009; Hess et al. 2016) over every heading of ``cells`` and every offset
    window[0] <= row <= window[1], window[2] <= col <= window[3], best bound first: a leaf that leaves the heap
    outscores everything still in it, so the leaves come out best first. Returns ``found`` (count, 3) as
    (a, row, col), their scores and how many were found; a leaf closer than the separations to one found before
    is skipped, as is any node where ``allowed`` (a max-pooled pyramid like ``levels`` over row, col, or empty for
    everywhere) holds nothing.

    Scores are multiplied by Karto's penalties for leaving the prior (offset 0, 0): ``angle_penalty[a]``, and
    max(1 - distance_gain * cells², minimum_distance_penalty); a node takes the penalty of its offset nearest the
    prior, the largest it holds, so its bound stays a bound."""
    keys = np.empty(1024)
    nodes = np.empty((1024, 4), np.int64)
    size = 0
    use_allowed = allowed.shape[0] > 0
    span = 1 << root_depth
    for a in range(cells.shape[0]):
        for row in range(window[0], window[1] + 1, span):
            for col in range(window[2], window[3] + 1, span):
                if use_allowed and allowed[root_depth, row, col] == 0:
                    continue
                score = node_score(levels, root_depth, cells, a, row, col) * angle_penalty[a] * _distance_penalty(
                    row, col, span, distance_gain, minimum_distance_penalty)
                keys, nodes, size = _push(keys, nodes, size, score, a, root_depth, row, col)
    found = np.zeros((count, 3), np.int64)
    scores = np.zeros(count)
    n = 0
    while size > 0 and n < count:
        key, a, depth, row, col = _pop(keys, nodes, size)
        size -= 1
        if _excluded(found, n, angles, a, depth, row, col, separation, angle_separation):
            continue
        if depth == 0:
            found[n, 0], found[n, 1], found[n, 2] = a, row, col
            scores[n] = key
            n += 1
            continue
        half = 1 << (depth - 1)
        for r in (row, row + half):
            for c in (col, col + half):
                if r > window[1] or c > window[3] or (use_allowed and allowed[depth - 1, r, c] == 0):
                    continue
                score = node_score(levels, depth - 1, cells, a, r, c) * angle_penalty[a] * _distance_penalty(
                    r, c, half, distance_gain, minimum_distance_penalty)
                keys, nodes, size = _push(keys, nodes, size, score, a, depth - 1, r, c)
    return found, scores, n


@njit(cache=True, nogil=True)
def candidate_scores(levels, cells, candidates):
    """The score of each candidate (a, row, col) row of ``candidates``: the sum of levels[0] at its returns."""
    out = np.empty(candidates.shape[0])
    for m in range(candidates.shape[0]):
        out[m] = node_score(levels, 0, cells, candidates[m, 0], candidates[m, 1], candidates[m, 2])
    return out


@njit(cache=True, nogil=True)
def _catmull_rom(t):
    """The weights of the four samples around t in [0, 1), and their derivatives (Keys' cubic, a = -1/2)."""
    t2 = t * t
    t3 = t2 * t
    weights = (0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0), 0.5 * (-3.0 * t3 + 4.0 * t2 + t),
               0.5 * (t3 - t2))
    slopes = (0.5 * (-3.0 * t2 + 4.0 * t - 1.0), 0.5 * (9.0 * t2 - 10.0 * t), 0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
              0.5 * (3.0 * t2 - 2.0 * t))
    return weights, slopes


@njit(cache=True, nogil=True)
def interpolate(data, origin_x, origin_y, resolution, x, y):
    """The bicubic through the cell centres at (x, y) and its gradient (zero outside the grid). Bicubic, not
    bilinear: a sum of piecewise-linear bumps peaks at cell centres, which would pull every match onto the lattice."""
    rows, cols = data.shape
    u = (x - origin_x) / resolution - 0.5
    v = (y - origin_y) / resolution - 0.5
    if not (-2.0 < u < cols + 1.0 and -2.0 < v < rows + 1.0):
        return 0.0, 0.0, 0.0
    c0 = int(math.floor(u))
    r0 = int(math.floor(v))
    wu, du = _catmull_rom(u - c0)
    wv, dv = _catmull_rom(v - r0)
    value = gx = gy = 0.0
    for j in range(4):
        row = r0 - 1 + j
        if row < 0 or row >= rows:
            continue
        for i in range(4):
            col = c0 - 1 + i
            if 0 <= col < cols:
                d = data[row, col]
                value += wv[j] * wu[i] * d
                gx += wv[j] * du[i] * d
                gy += dv[j] * wu[i] * d
    return value, gx / resolution, gy / resolution


@njit(cache=True, nogil=True)
def mean_response(data, origin_x, origin_y, resolution, points, pose):
    """The mean interpolated field (held to 0..1) at ``points`` (base frame) placed at ``pose``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    total = 0.0
    for i in range(points.shape[0]):
        px, py = points[i, 0], points[i, 1]
        value = interpolate(data, origin_x, origin_y, resolution, pose[0] + c * px - s * py,
                            pose[1] + s * px + c * py)[0]
        total += min(max(value, 0.0), 1.0)
    return total / max(points.shape[0], 1)


@njit(cache=True, nogil=True)
def _normal_equations(data, origin_x, origin_y, resolution, points, pose, target):
    """Cost sum (target - M(T p))^2 over the returns, with Gauss-Newton's J^T J and J^T r at ``pose``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    hessian = np.zeros((3, 3))
    gradient = np.zeros(3)
    jacobian = np.zeros(3)
    cost = 0.0
    for i in range(points.shape[0]):
        px, py = points[i, 0], points[i, 1]
        value, gx, gy = interpolate(data, origin_x, origin_y, resolution, pose[0] + c * px - s * py,
                                    pose[1] + s * px + c * py)
        residual = target - value
        jacobian[0], jacobian[1] = -gx, -gy
        jacobian[2] = -(gx * (-s * px - c * py) + gy * (c * px - s * py))
        cost += residual * residual
        for k in range(3):
            gradient[k] += jacobian[k] * residual
            for m in range(3):
                hessian[k, m] += jacobian[k] * jacobian[m]
    return cost, hessian, gradient


@njit(cache=True, nogil=True)
def refine_pose(data, origin_x, origin_y, resolution, points, start, lower, upper, target, iterations):
    """Levenberg-Marquardt on the interpolated field from ``start``, every step held inside [lower, upper] (the
    search window), a step kept only if it lowers the cost: the sub-cell pose the lattice search cannot give."""
    pose = start.copy()
    cost, hessian, gradient = _normal_equations(data, origin_x, origin_y, resolution, points, pose, target)
    damping = 1e-3
    for _ in range(iterations):
        system = hessian.copy()
        for k in range(3):
            system[k, k] += damping * hessian[k, k] + 1e-9
        trial = np.minimum(np.maximum(pose - np.linalg.solve(system, gradient), lower), upper)
        trial_cost, trial_hessian, trial_gradient = _normal_equations(data, origin_x, origin_y, resolution,
                                                                      points, trial, target)
        if trial_cost < cost:
            moved = np.max(np.abs(trial - pose))
            pose, cost, hessian, gradient = trial, trial_cost, trial_hessian, trial_gradient
            damping = max(damping * 0.3, 1e-9)
            if moved < 1e-7:
                break
        else:
            damping *= 10.0
            if damping > 1e6:
                break
    return pose
