"""Compiled loops of amcl: the laser models' particle weights and KLD resampling.

Why numba: each model evaluates every particle against every beam (2000 particles x 2 x 683 beams is 2.7 million
map look-ups, or as many ray casts for the beam model) and KLD resampling decides after every drawn particle whether
it has enough, by the number of histogram bins filled so far; vectorised numpy pays for temporaries of that size or
cannot stop early. The plain numpy references the tests compare against are in testing/amcl_reference.py. Every
kernel is compiled with ``cache=True`` and releases the GIL. They call nothing of other modules, so numba's per-file
cache stays consistent by itself (kernel_cache.py is for kernels that inline other files).

They run on one thread. With numba's parallel loops on two threads the likelihood field with 2 x 683 beams took half
the time on an idle core, but on cores shared with other processes (the simulator, move_base) every parallel loop
waits for its slowest thread: an update of 2 x 30 beams went from 0.5 ms to 15 ms.

The likelihood-field loops are compiled with fastmath and numpy's error model (no division checks, free
reassociation of the end point's sum): 15 % faster, and the end cell is the same but for end points within a
rounding error of a cell edge.

Poses come in the grid frame in cell units (AmclMap.to_grid): a particle at (gx, gy, gyaw) lies in cell
(floor(gx), floor(gy)), i.e. row floor(gy) and column floor(gx) of the [height, width] arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_INV_SQRT2 = 0.7071067811865476


@njit(cache=True, nogil=True, inline="always", fastmath=True, error_model="numpy")
def _end_cell(pose, c, s, end, width, height):
    """Row-major index of the cell a beam end falls in, or -1 beyond the map."""
    hx = pose[0] + c * end[0] - s * end[1]
    hy = pose[1] + s * end[0] + c * end[1]
    if hx >= 0.0 and hy >= 0.0:
        col, row = int(hx), int(hy)
        if col < width and row < height:
            return row * width + col
    return -1


@njit(cache=True, nogil=True, fastmath=True, error_model="numpy")
def likelihood_field_weights(poses, beam_ends, pz_table, pz_off_map, out):
    """amcl's likelihood_field model: out[j] = 1 + sum over beams of pz^3, pz read from ``pz_table`` at the
    cell of the beam's end point (``pz_off_map`` beyond the map). ``beam_ends`` (M, 2): end points in the base
    frame, in cells."""
    height, width = pz_table.shape
    flat = pz_table.ravel()
    for j in range(poses.shape[0]):
        c, s = math.cos(poses[j, 2]), math.sin(poses[j, 2])
        p = 1.0
        for b in range(beam_ends.shape[0]):
            cell = _end_cell(poses[j], c, s, beam_ends[b], width, height)
            pz = flat[cell] if cell >= 0 else pz_off_map
            p += pz * pz * pz
        out[j] = p


@njit(cache=True, nogil=True, fastmath=True, error_model="numpy")
def likelihood_field_prob_weights(poses, beam_ends, log_pz_table, log_pz_off_map, near_obstacle, beamskip, slots,
                                  skip_threshold, error_threshold, out):
    """amcl's likelihood_field_prob model: out[j] = the product of the beams' pz (``log_pz_table``: ln pz per
    cell). With ``beamskip`` only the beams whose end more than ``skip_threshold`` of the particles find in the map
    and near an obstacle count, unless at least ``error_threshold`` of the ``slots`` beam places (laser_max_beams)
    would be skipped. Returns the number of beams used."""
    n, m = poses.shape[0], beam_ends.shape[0]
    height, width = log_pz_table.shape
    flat_log, flat_near = log_pz_table.ravel(), near_obstacle.ravel()
    use = np.ones(m, dtype=np.bool_)
    if beamskip:
        for b in range(m):
            agree = 0
            for j in range(n):
                cell = _end_cell(poses[j], math.cos(poses[j, 2]), math.sin(poses[j, 2]), beam_ends[b], width, height)
                if cell >= 0 and flat_near[cell]:
                    agree += 1
            use[b] = agree / n > skip_threshold
        if slots - use.sum() >= slots * error_threshold:
            use[:] = True
    ends = beam_ends[use] if beamskip else beam_ends     # without beam skipping no beam is looked at twice
    for j in range(n):
        c, s = math.cos(poses[j, 2]), math.sin(poses[j, 2])
        log_p = 0.0
        for b in range(ends.shape[0]):
            cell = _end_cell(poses[j], c, s, ends[b], width, height)
            log_p += flat_log[cell] if cell >= 0 else log_pz_off_map
        out[j] = math.exp(log_p)
    return use.sum()


@njit(cache=True, nogil=True, inline="always")
def _blocked(blocked, col, row):
    return col < 0 or row < 0 or row >= blocked.shape[0] or col >= blocked.shape[1] or blocked[row, col] != 0


@njit(cache=True, nogil=True)
def cast_range(ox, oy, angle, max_cells, blocked, clearance):
    """amcl's map_calc_range in cells: Bresenham from the cell of (ox, oy) towards ``max_cells`` along ``angle``,
    the distance between cell indices to the first blocked or off-map cell, or -1.0 if none. Like amcl it checks one
    cell beyond the end. Where ``clearance`` says the next cells are all free it jumps over them, landing exactly on
    the cell the step-by-step walk would reach."""
    x0, y0 = int(math.floor(ox)), int(math.floor(oy))
    x1 = int(math.floor(ox + max_cells * math.cos(angle)))
    y1 = int(math.floor(oy + max_cells * math.sin(angle)))
    steep = abs(y1 - y0) > abs(x1 - x0)
    if steep:
        x0, y0, x1, y1 = y0, x0, y1, x1
    deltax, deltay = abs(x1 - x0), abs(y1 - y0)
    xstep = 1 if x0 < x1 else -1
    ystep = 1 if y0 < y1 else -1
    x, y, error = x0, y0, 0
    end = x1 + xstep
    while True:
        col, row = (y, x) if steep else (x, y)
        if _blocked(blocked, col, row):
            return math.sqrt((x - x0) ** 2 + (y - y0) ** 2)
        if x == end:
            return -1.0
        jump = min(int(clearance[row, col] * _INV_SQRT2) - 1, abs(end - x) - 1)
        if jump >= 1:
            total = error + jump * deltay
            rises = (2 * total + deltax) // (2 * deltax)
            x += jump * xstep
            y += rises * ystep
            error = total - rises * deltax
            continue
        x += xstep
        error += deltay
        if 2 * error >= deltax:
            y += ystep
            error -= deltax


@njit(cache=True, nogil=True)
def beam_model_weights(poses, sensor, bearings, ranges, range_max, resolution, blocked, clearance, z, out):
    """amcl's beam model: out[j] = 1 + sum over beams of pz^3, the expected range ray-cast in the map from the
    particle's sensor. ``sensor`` = (x, y in cells, yaw) in the base frame; ``bearings`` in the sensor frame;
    ``ranges`` in m (max-range readings exactly ``range_max``); z = (z_hit, z_short, z_max, z_rand, sigma_hit,
    lambda_short)."""
    z_hit, z_short, z_max, z_rand, sigma_hit, lambda_short = z[0], z[1], z[2], z[3], z[4], z[5]
    denominator = 2.0 * sigma_hit * sigma_hit
    max_cells = range_max / resolution
    for j in range(poses.shape[0]):
        c, s = math.cos(poses[j, 2]), math.sin(poses[j, 2])
        ox = poses[j, 0] + c * sensor[0] - s * sensor[1]
        oy = poses[j, 1] + s * sensor[0] + c * sensor[1]
        p = 1.0
        for b in range(bearings.shape[0]):
            cells = cast_range(ox, oy, poses[j, 2] + sensor[2] + bearings[b], max_cells, blocked, clearance)
            expected = range_max if cells < 0.0 else cells * resolution
            obs = ranges[b]
            dz = obs - expected
            pz = z_hit * math.exp(-(dz * dz) / denominator)
            if dz < 0.0:
                pz += z_short * lambda_short * math.exp(-lambda_short * obs)
            if obs == range_max:
                pz += z_max
            if obs < range_max:
                pz += z_rand / range_max
            p += pz * pz * pz
        out[j] = p


@njit(cache=True, nogil=True)
def kld_limit(k, min_n, max_n, err, z):
    """Particles KLD sampling needs once ``k`` histogram bins are filled (Fox 2003), within [min_n, max_n];
    like amcl's pf_resample_limit, one bin (or none) asks for max_n."""
    if k <= 1:
        return max_n
    b = 2.0 / (9.0 * (k - 1))
    x = 1.0 - b + math.sqrt(b) * z
    n = int(math.ceil((k - 1) / (2.0 * err) * x * x * x))
    return min(max(n, min_n), max_n)


@njit(cache=True, nogil=True, inline="always")
def bin_key(x, y, yaw, bin_xy, bin_yaw, yaw_bins):
    """One int64 per (x, y, yaw) histogram bin; yaw bins wrap around at +-pi."""
    kx = int(math.floor(x / bin_xy)) + (1 << 20)
    ky = int(math.floor(y / bin_xy)) + (1 << 20)
    ka = int(math.floor((yaw + math.pi) / bin_yaw)) % yaw_bins
    return (kx << 42) | (ky << 21) | ka


@njit(cache=True, nogil=True)
def kld_resample(poses, cumulative, u_pick, u_inject, random_poses, w_diff, bin_xy, bin_yaw, yaw_bins, min_n,
                 max_n, err, z, out):
    """amcl's pf_update_resample: draw particles in proportion to their weight (``u_pick`` in [0, 1) scaled to
    the weights' total; ``cumulative`` has N + 1 entries from 0), or the next of ``random_poses`` where
    ``u_inject`` < ``w_diff``, filling a histogram as it goes, and stop as soon as there are more than
    kld_limit(bins filled). Returns the count written to ``out``."""
    capacity = 1
    while capacity < 4 * max_n:
        capacity *= 2
    keys = np.full(capacity, -1, dtype=np.int64)
    filled = 0
    total = cumulative[-1]
    count = 0
    for n in range(max_n):
        if u_inject[n] < w_diff:
            out[n, :] = random_poses[n, :]
        else:
            i = np.searchsorted(cumulative, u_pick[n] * total, side="right") - 1
            i = min(max(i, 0), poses.shape[0] - 1)
            out[n, :] = poses[i, :]
        key = bin_key(out[n, 0], out[n, 1], out[n, 2], bin_xy, bin_yaw, yaw_bins)
        slot = ((key ^ (key >> 29)) * 2654435761) & (capacity - 1)
        while keys[slot] != -1 and keys[slot] != key:
            slot = (slot + 1) & (capacity - 1)
        if keys[slot] == -1:
            keys[slot] = key
            filled += 1
        count = n + 1
        if count > kld_limit(filled, min_n, max_n, err, z):
            break
    return count
