"""Compiled solver of the TEB optimiser: banded Cholesky, the step, and the Levenberg-Marquardt
inner loop, which evaluates the band through edge_kernels.evaluate.

J^T J is held as LAPACK-style lower bands, h[i - j, j] = H[i, j] (see edge_kernels for the
packing of the variables). Every kernel is compiled with ``cache=True`` and releases the GIL.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from simplebot_navigation.teb.edge_kernels import MIN_TIME_DIFF, evaluate, normalize_angle, workspace


@njit(cache=True, nogil=True)
def banded_cholesky(ab):
    """In place: lower bands of a symmetric positive definite matrix -> those of its Cholesky
    factor L. False when the matrix is not (numerically) positive definite."""
    bw = ab.shape[0] - 1
    size = ab.shape[1]
    for j in range(size):
        d = ab[0, j]
        for k in range(max(0, j - bw), j):
            d -= ab[j - k, k] * ab[j - k, k]
        if not d > 0.0 or not math.isfinite(d):
            return False
        ljj = math.sqrt(d)
        ab[0, j] = ljj
        for i in range(j + 1, min(size, j + bw + 1)):
            s = ab[i - j, j]
            for k in range(max(0, i - bw), j):
                s -= ab[i - k, k] * ab[j - k, k]
            ab[i - j, j] = s / ljj
    return True


@njit(cache=True, nogil=True)
def banded_solve(ab, b, x):
    """x = (L L^T)^-1 b for the banded Cholesky factor L."""
    bw = ab.shape[0] - 1
    size = ab.shape[1]
    for i in range(size):
        s = b[i]
        for k in range(max(0, i - bw), i):
            s -= ab[i - k, k] * x[k]
        x[i] = s / ab[0, i]
    for i in range(size - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, min(size, i + bw + 1)):
            s -= ab[k - i, i] * x[k]
        x[i] = s / ab[0, i]


@njit(cache=True, nogil=True)
def apply_step(poses, dts, step, new_poses, new_dts):
    """Add a step of the packed variables; time differences stay above MIN_TIME_DIFF."""
    n = dts.shape[0]
    new_poses[:] = poses
    for i in range(n):
        new_dts[i] = max(dts[i] + step[4 * i], MIN_TIME_DIFF)
    for k in range(1, n):
        new_poses[k, 0] += step[4 * k - 3]
        new_poses[k, 1] += step[4 * k - 2]
        new_poses[k, 2] = normalize_angle(poses[k, 2] + step[4 * k - 1])


@njit(cache=True, nogil=True)
def levenberg_marquardt(poses, dts, params, edges, model, n_res, iterations):
    """g2o's Levenberg-Marquardt on the band, in place: lambda starts at 1e-5 * max diag(H), shrinks
    on gain and doubles its growth factor on each rejected step (at most 10 trials per
    iteration). Returns the final chi2."""
    n = dts.shape[0]
    if n < 1:
        return 0.0
    r, chi2, h, g, work = workspace(n, n_res)
    n_vars = 4 * n - 3
    damped = np.empty_like(h)
    step = np.empty(n_vars)
    trial_poses, trial_dts = np.empty_like(poses), np.empty_like(dts)
    chi = evaluate(poses, dts, params, edges, model, True, r, chi2, h, g, work)
    lam = -1.0
    nu = 2.0
    for iteration in range(iterations):
        if lam < 0.0:
            lam = 1e-5 * h[0].max()
        accepted = False
        for _trial in range(10):
            damped[:] = h
            damped[0] += lam
            if not banded_cholesky(damped):
                lam *= nu
                nu *= 2.0
                continue
            banded_solve(damped, g, step)
            step *= -1.0
            apply_step(poses, dts, step, trial_poses, trial_dts)
            new_chi = evaluate(trial_poses, trial_dts, params, edges, model, False, r, chi2, h, g, work)
            gain = 0.0
            for j in range(n_vars):
                gain += step[j] * (lam * step[j] - g[j])
            rho = (chi - new_chi) / (gain + 1e-3)
            if rho > 0 and math.isfinite(new_chi):
                lam *= max(1.0 / 3.0, min(1.0 - (2.0 * rho - 1.0) ** 3, 2.0 / 3.0))
                nu = 2.0
                poses[:] = trial_poses
                dts[:] = trial_dts
                chi = new_chi
                accepted = True
                break
            lam *= nu
            nu *= 2.0
        if not accepted or iteration == iterations - 1:
            break
        h[:] = 0.0
        g[:] = 0.0
        evaluate(poses, dts, params, edges, model, True, r, chi2, h, g, work)
    return chi

