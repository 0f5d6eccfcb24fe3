"""Plain numpy (and plain Python) versions of amcl's compiled kernels: the oracle localization/amcl_kernels.py is
tested against. Written for reading, not speed: the beam model walks every ray cell by cell as amcl's
map_calc_range does, without the kernel's jumps, and KLD resampling draws all particles at once and finds where
amcl's loop would have stopped."""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.localization.clusters import bins_of


def beam_end_cells(poses: np.ndarray, beam_ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cols, rows) of every (particle, beam) end point; poses in the grid frame, ends in cells."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    hx = poses[:, 0:1] + c * beam_ends[None, :, 0] - s * beam_ends[None, :, 1]
    hy = poses[:, 1:2] + s * beam_ends[None, :, 0] + c * beam_ends[None, :, 1]
    cols, rows = np.floor(hx).astype(np.int64), np.floor(hy).astype(np.int64)
    return cols, rows


def pz_of_ends(poses, beam_ends, pz_table, pz_off_map) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(pz, inside, rows, cols) for every (particle, beam)."""
    cols, rows = beam_end_cells(poses, beam_ends)
    height, width = pz_table.shape
    inside = (cols >= 0) & (rows >= 0) & (cols < width) & (rows < height)
    pz = np.where(inside, pz_table[np.clip(rows, 0, height - 1), np.clip(cols, 0, width - 1)], pz_off_map)
    return pz, inside, np.clip(rows, 0, height - 1), np.clip(cols, 0, width - 1)


def likelihood_field_weights(poses, beam_ends, pz_table, pz_off_map) -> np.ndarray:
    pz, _, _, _ = pz_of_ends(poses, beam_ends, pz_table, pz_off_map)
    return 1.0 + (pz ** 3).sum(axis=1)


def likelihood_field_prob_weights(poses, beam_ends, pz_table, pz_off_map, near_obstacle, beamskip, slots,
                                  skip_threshold, error_threshold) -> np.ndarray:
    pz, inside, rows, cols = pz_of_ends(poses, beam_ends, pz_table, pz_off_map)
    use = np.ones(beam_ends.shape[0], dtype=bool)
    if beamskip:
        agree = (inside & near_obstacle[rows, cols]).sum(axis=0)
        use = agree / len(poses) > skip_threshold
        if slots - use.sum() >= slots * error_threshold:
            use[:] = True
    return np.exp(np.log(pz[:, use]).sum(axis=1))


def cast_range(ox, oy, angle, max_cells, blocked) -> float:
    """amcl's map_calc_range, one cell at a time: cells from the start to one beyond the end; -1.0 if all free."""
    x0, y0 = math.floor(ox), math.floor(oy)
    x1, y1 = math.floor(ox + max_cells * math.cos(angle)), math.floor(oy + max_cells * math.sin(angle))
    steep = abs(y1 - y0) > abs(x1 - x0)
    if steep:
        x0, y0, x1, y1 = y0, x0, y1, x1
    deltax, deltay = abs(x1 - x0), abs(y1 - y0)
    xstep, ystep = (1 if x0 < x1 else -1), (1 if y0 < y1 else -1)
    height, width = blocked.shape

    def hit(x, y):
        col, row = (y, x) if steep else (x, y)
        return not (0 <= col < width and 0 <= row < height) or blocked[row, col]

    x, y, error = x0, y0, 0
    if hit(x, y):
        return 0.0
    while x != x1 + xstep:
        x += xstep
        error += deltay
        if 2 * error >= deltax:
            y += ystep
            error -= deltax
        if hit(x, y):
            return math.hypot(x - x0, y - y0)
    return -1.0


def beam_model_weights(poses, sensor, bearings, ranges, range_max, resolution, blocked, z) -> np.ndarray:
    z_hit, z_short, z_max, z_rand, sigma_hit, lambda_short = z
    out = np.empty(len(poses))
    for j, (gx, gy, yaw) in enumerate(poses):
        ox = gx + math.cos(yaw) * sensor[0] - math.sin(yaw) * sensor[1]
        oy = gy + math.sin(yaw) * sensor[0] + math.cos(yaw) * sensor[1]
        cells = np.array([cast_range(ox, oy, yaw + sensor[2] + b, range_max / resolution, blocked)
                          for b in bearings])
        expected = np.where(cells < 0, range_max, cells * resolution)
        dz = ranges - expected
        pz = z_hit * np.exp(-dz ** 2 / (2 * sigma_hit ** 2))
        pz += np.where(dz < 0, z_short * lambda_short * np.exp(-lambda_short * ranges), 0.0)
        pz += np.where(ranges == range_max, z_max, 0.0) + np.where(ranges < range_max, z_rand / range_max, 0.0)
        out[j] = 1.0 + (pz ** 3).sum()
    return out


def kld_limit(k, min_n, max_n, err, z) -> np.ndarray:
    """Fox's KLD bound for arrays of filled-bin counts k, clamped; k <= 1 asks for max_n as in amcl."""
    k = np.asarray(k, dtype=float)
    km1 = np.maximum(k - 1, 1)
    b = 2 / (9 * km1)
    n = np.ceil((k - 1) / (2 * err) * (1 - b + np.sqrt(b) * z) ** 3)
    return np.where(k <= 1, max_n, np.clip(n, min_n, max_n)).astype(np.int64)


def kld_resample(poses, cumulative, u_pick, u_inject, random_poses, w_diff, min_n, max_n, err, z) -> np.ndarray:
    """All max_n draws at once; the count is the first n whose n particles exceed the bound for the bins they fill."""
    picked = np.searchsorted(cumulative, u_pick * cumulative[-1], side="right") - 1
    drawn = poses[np.clip(picked, 0, len(poses) - 1)]
    if w_diff > 0:
        inject = u_inject < w_diff
        drawn[inject] = random_poses[inject]
    bins = bins_of(drawn)
    _, first = np.unique(bins, axis=0, return_index=True)
    is_new = np.zeros(max_n, dtype=bool)
    is_new[first] = True
    filled = np.cumsum(is_new)
    counts = np.arange(1, max_n + 1)
    over = np.nonzero(counts > kld_limit(filled, min_n, max_n, err, z))[0]
    count = over[0] + 1 if len(over) else max_n
    return drawn[:count]


def obstacle_distance(occupied: np.ndarray, resolution: float, max_dist: float) -> np.ndarray:
    """Brute force: every cell centre's distance to every occupied cell centre, the least, capped."""
    rows, cols = np.nonzero(occupied)
    grid_rows, grid_cols = np.indices(occupied.shape)
    best = np.full(occupied.shape, np.inf)
    for r, c in zip(rows, cols):
        best = np.minimum(best, np.hypot(grid_rows - r, grid_cols - c) * resolution)
    return np.minimum(best, max_dist)
