"""Compiled edges of the TEB optimiser: every edge family's errors and Jacobians, accumulated into
banded normal equations (solver_kernels runs the Levenberg-Marquardt loop on them,
footprint_kernels measures the footprint against obstacles).

Why numba: a band has a few dozen poses and a few hundred edges, so a vectorised numpy evaluation
spends its time in the fixed cost of some fifty small array calls per evaluation, not in
arithmetic, and a 20 Hz control cycle runs hundreds of evaluations (several bands, four outer
and five inner iterations, up to ten trial steps each). Written as plain loops over edges and
compiled, one evaluation costs microseconds, the normal equations are accumulated straight into
banded storage without scatter indices, and a whole inner loop (evaluate, assemble, damped
banded Cholesky solve, step, chi2) is one call. testing/teb_reference.py keeps the vectorised numpy
evaluation as the oracle the tests hold these kernels to. Every kernel is compiled with
``cache=True``, so only the very first process pays the compile time (see warm_up()), and
releases the GIL.

Variables are packed pose-major, [dT_0, x_1, y_1, th_1, dT_1, ..., x_{n-1}, y_{n-1}, th_{n-1},
dT_{n-1}]: pose k -> columns 4k-3..4k-1, dT_i -> column 4i, the fixed poses 0 and n -> -1. The
widest edge (an acceleration over two segments) spans BANDWIDTH columns, so J^T J is stored as
LAPACK-style lower bands, h[i - j, j] = H[i, j].

The edge set of one outer iteration is the tuple (obstacle pose indices, obstacle points, gap
clearances, via pose indices, via points, dynamic obstacle pose indices, dynamic obstacles (x, y,
radius) predicted at their pose's time); footprint models are described in footprint_kernels.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from simplebot_navigation.teb.footprint_kernels import footprint_distance_trig

#: Columns between the first and last free variable of the widest edge (interior acceleration).
BANDWIDTH = 10
MIN_TIME_DIFF = 1e-3
#: Edge families, in the order of the residual vector and of the per-family chi2.
#: The dynamic obstacles come last, so a band without them sums the same chi2 terms in the same order.
FAMILIES = ("vel", "acc", "acc_start", "acc_goal", "kin", "time", "obstacle", "via", "prefer_rotdir",
            "dynamic_obstacle")
F_VEL, F_ACC, F_ACC_START, F_ACC_GOAL, F_KIN, F_TIME, F_OBSTACLE, F_VIA, F_PREFER_ROTDIR, F_DYNAMIC = range(10)
N_FAMILIES = len(FAMILIES)
#: Rotations at the start of the band a preferred turning direction applies to (AddEdgesPreferRotDir).
PREFER_ROTDIR_ROTATIONS = 3

# Slots of the edge parameter vector (see edge_parameters).
(P_EPS, P_VEL_W_X, P_VEL_W_TH, P_VEL_LO_X, P_VEL_LO_TH, P_VEL_HI_X, P_VEL_HI_TH, P_ACC_W_X, P_ACC_W_TH,
 P_ACC_LIM_X, P_ACC_LIM_TH, P_START_V, P_START_OMEGA, P_FREE_GOAL, P_W_NH, P_W_FD, P_W_TIME, P_W_OBSTACLE,
 P_MIN_OBSTACLE, P_EXPONENT, P_INFLATION, P_W_INFLATION, P_INFLATION_DIST, P_W_VIA, P_ROTDIR, P_W_ROTDIR,
 P_W_DYNAMIC, P_DYNAMIC_INFLATION, P_W_DYNAMIC_INFLATION, P_DYNAMIC_INFLATION_DIST, N_PARAMS) = range(31)

_TWO_PI = 2.0 * math.pi


def edge_parameters(cfg, obstacle_weight: float, start_velocity, free_goal_vel: bool,
                    with_inflation: bool, rotdir: int = 0, dynamic_weight: float = 0.0) -> np.ndarray:
    """The scalars every edge family needs, square roots of the weights included (a residual is
    sqrt(weight) * error, so chi2 carries the weight). rotdir: the preferred turning direction,
    +1 left, -1 right, 0 none; without one the prefer_rotdir weight is 0 and the family is skipped.
    dynamic_weight: weight_dynamic_obstacle times the outer loop's multiplier."""
    robot, obstacles, optim = cfg.robot, cfg.obstacles, cfg.optim
    p = np.zeros(N_PARAMS)
    p[P_EPS] = optim.penalty_epsilon
    p[P_VEL_W_X], p[P_VEL_W_TH] = math.sqrt(optim.weight_max_vel_x), math.sqrt(optim.weight_max_vel_theta)
    p[P_VEL_LO_X], p[P_VEL_LO_TH] = -robot.max_vel_x_backwards, -robot.max_vel_theta
    p[P_VEL_HI_X], p[P_VEL_HI_TH] = robot.max_vel_x, robot.max_vel_theta
    p[P_ACC_W_X], p[P_ACC_W_TH] = math.sqrt(optim.weight_acc_lim_x), math.sqrt(optim.weight_acc_lim_theta)
    p[P_ACC_LIM_X], p[P_ACC_LIM_TH] = robot.acc_lim_x, robot.acc_lim_theta
    p[P_START_V], p[P_START_OMEGA] = start_velocity
    p[P_FREE_GOAL] = float(free_goal_vel)
    p[P_W_NH], p[P_W_FD] = math.sqrt(optim.weight_kinematics_nh), math.sqrt(optim.weight_kinematics_forward_drive)
    p[P_W_TIME] = math.sqrt(optim.weight_optimaltime)
    p[P_W_OBSTACLE], p[P_MIN_OBSTACLE] = math.sqrt(obstacle_weight), obstacles.min_obstacle_dist
    p[P_EXPONENT] = optim.obstacle_cost_exponent
    p[P_INFLATION] = float(with_inflation)
    p[P_W_INFLATION], p[P_INFLATION_DIST] = math.sqrt(optim.weight_inflation), obstacles.inflation_dist
    p[P_W_VIA] = math.sqrt(optim.weight_viapoint)
    p[P_ROTDIR], p[P_W_ROTDIR] = float(rotdir), (math.sqrt(optim.weight_prefer_rotdir) if rotdir else 0.0)
    p[P_W_DYNAMIC], p[P_DYNAMIC_INFLATION] = math.sqrt(dynamic_weight), float(with_dynamic_inflation(cfg))
    p[P_W_DYNAMIC_INFLATION] = math.sqrt(optim.weight_dynamic_obstacle_inflation)
    p[P_DYNAMIC_INFLATION_DIST] = obstacles.dynamic_obstacle_inflation_dist
    return p


def with_dynamic_inflation(cfg) -> bool:
    """The second error of a dynamic obstacle edge counts only beyond min_obstacle_dist."""
    return (cfg.obstacles.dynamic_obstacle_inflation_dist > cfg.obstacles.min_obstacle_dist
            and cfg.optim.weight_dynamic_obstacle_inflation > 0)


def residual_count(n: int, n_obstacle: int, n_via: int, n_dynamic: int, params: np.ndarray) -> int:
    """Length of the residual vector of a band with n time differences."""
    return (2 * n + (2 * (n - 1) if n >= 2 else 0) + 2 + (0 if params[P_FREE_GOAL] else 2) + 3 * n
            + n_obstacle * (2 if params[P_INFLATION] else 1) + 2 * n_via
            + (min(n, PREFER_ROTDIR_ROTATIONS) if params[P_W_ROTDIR] else 0)
            + n_dynamic * (2 if params[P_DYNAMIC_INFLATION] else 1))


# -- edges -----------------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def normalize_angle(a):
    """geometry.normalize_theta for a scalar, compiled (kernels cannot call numpy-generic code)."""
    return (a + math.pi) % _TWO_PI - math.pi


@njit(cache=True, nogil=True)
def _bound_to_interval(value, lower, upper, eps):
    """Penalty and derivative: zero inside [lower+eps, upper-eps], linear excess outside."""
    lo, hi = lower + eps, upper - eps
    if value < lo:
        return lo - value, -1.0
    if value > hi:
        return value - hi, 1.0
    return 0.0, 0.0


@njit(cache=True, nogil=True)
def _pose_col(k, n):
    return 4 * k - 3 if 0 < k < n else -1


@njit(cache=True, nogil=True)
def _accumulate(h, g, cols, jac, res):
    """Add one residual's J^T J and J^T r (free columns only; a column appears once per edge)."""
    for a in range(cols.shape[0]):
        ca = cols[a]
        ja = jac[a]
        if ca < 0 or ja == 0.0:
            continue
        g[ca] += ja * res
        for b in range(cols.shape[0]):
            cb = cols[b]
            if 0 <= cb <= ca:
                h[ca - cb, cb] += ja * jac[b]


@njit(cache=True, nogil=True)
def _set_pose_cols(cols, k, n):
    """Columns of pose k at cols[0:3] (-1: a fixed pose)."""
    c = _pose_col(k, n)
    for j in range(3):
        cols[j] = c + j if c >= 0 else -1


@njit(cache=True, nogil=True)
def _accumulate_pose(h, g, cols, jac, k, n, scale, gx, gy, gth, res):
    """Add a residual that depends on pose k alone, with Jacobian scale * (gx, gy, gth)."""
    _set_pose_cols(cols, k, n)
    jac[0], jac[1], jac[2] = scale * gx, scale * gy, scale * gth
    _accumulate(h, g, cols[:3], jac[:3], res)


@njit(cache=True, nogil=True)
def _set_segment_cols(cols, i, n):
    """Columns of pose i and pose i+1 at cols[0:6]."""
    _set_pose_cols(cols, i, n)
    _set_pose_cols(cols[3:], i + 1, n)


@njit(cache=True, nogil=True)
def evaluate(poses, dts, params, edges, model, jacobian, r, chi2, h, g, work):
    """Weighted residuals of every edge into r (family after family, as FAMILIES lists them; the two
    kinds of a family one after the other: all v rows, then all omega rows, ...), their squares
    summed per family into chi2 (zeroed here), and with ``jacobian`` J^T J and J^T r added into the
    zeroed h and g. Scratch (see workspace): vw (2, n) and jvw (2, n, 7), each segment's
    (v, omega) and their Jacobians over (pose i, pose i+1, dT_i); trig (2, n+1), the cosine and
    sine of every heading; cols and jac (16,), one residual's Jacobian row."""
    vw, jvw, trig, cols, jac = work
    obst_pose, obst_point, obst_gap, via_pose, via_point, dyn_pose, dyn_obstacle = edges
    n = dts.shape[0]
    eps = params[P_EPS]
    chi2[:] = 0.0
    for k in range(n + 1):
        trig[0, k], trig[1, k] = math.cos(poses[k, 2]), math.sin(poses[k, 2])
    for i in range(n):
        dx, dy = poses[i + 1, 0] - poses[i, 0], poses[i + 1, 1] - poses[i, 1]
        c0, s0 = trig[0, i], trig[1, i]
        dist = math.hypot(dx, dy)
        proj = dx * c0 + dy * s0
        u = 100.0 * proj
        sig = u / (1.0 + abs(u))
        inv_dt = 1.0 / dts[i]
        v = sig * dist * inv_dt
        omega = normalize_angle(poses[i + 1, 2] - poses[i, 2]) * inv_dt
        vw[0, i], vw[1, i] = v, omega
        if jacobian:
            # v = sigmoid(100 proj) |d| / dT: the sign of the motion along the heading, smoothed
            a = 100.0 / (1.0 + abs(u)) ** 2 * dist * inv_dt
            b = sig / dist * inv_dt if dist > 1e-12 else 0.0
            jv = jvw[0, i]
            jv[0] = -a * c0 - b * dx
            jv[1] = -a * s0 - b * dy
            jv[2] = a * (dy * c0 - dx * s0)
            jv[3] = a * c0 + b * dx
            jv[4] = a * s0 + b * dy
            jv[5] = 0.0
            jv[6] = -v * inv_dt
            jw = jvw[1, i]
            jw[:] = 0.0
            jw[2], jw[5], jw[6] = -inv_dt, inv_dt, -omega * inv_dt
    row = 0

    # velocity
    for kind in range(2):
        w, lo, hi = params[P_VEL_W_X + kind], params[P_VEL_LO_X + kind], params[P_VEL_HI_X + kind]
        for i in range(n):
            e, de = _bound_to_interval(vw[kind, i], lo, hi, eps)
            r[row] = w * e
            chi2[F_VEL] += r[row] * r[row]
            if jacobian and de != 0.0:
                _set_segment_cols(cols, i, n)
                cols[6] = 4 * i
                for j in range(7):
                    jac[j] = w * de * jvw[kind, i, j]
                _accumulate(h, g, cols[:7], jac[:7], r[row])
            row += 1

    # acceleration over two segments; a pose shared by both gets the sum of its two columns
    for kind in range(2):
        w, lim = params[P_ACC_W_X + kind], params[P_ACC_LIM_X + kind]
        for i in range(n - 1):
            ssum = dts[i] + dts[i + 1]
            acc = 2.0 * (vw[kind, i + 1] - vw[kind, i]) / ssum
            e, de = _bound_to_interval(acc, -lim, lim, eps)
            r[row] = w * e
            chi2[F_ACC] += r[row] * r[row]
            if jacobian and de != 0.0:
                f = w * de / ssum
                j0, j1 = jvw[kind, i], jvw[kind, i + 1]
                _set_segment_cols(cols, i, n)
                _set_pose_cols(cols[6:], i + 2, n)
                for j in range(3):
                    jac[j] = -2.0 * j0[j] * f
                    jac[3 + j] = (2.0 * j1[j] - 2.0 * j0[3 + j]) * f
                    jac[6 + j] = 2.0 * j1[3 + j] * f
                cols[9], cols[10] = 4 * i, 4 * (i + 1)
                jac[9] = (-2.0 * j0[6] - acc) * f
                jac[10] = (2.0 * j1[6] - acc) * f
                _accumulate(h, g, cols[:11], jac[:11], r[row])
            row += 1

    # start (odometry velocity) and goal (zero unless free_goal_vel) accelerations
    for end in range(2 if params[P_FREE_GOAL] == 0.0 else 1):
        i = 0 if end == 0 else n - 1
        sign = 1.0 if end == 0 else -1.0
        family = F_ACC_START if end == 0 else F_ACC_GOAL
        for kind in range(2):
            w, lim = params[P_ACC_W_X + kind], params[P_ACC_LIM_X + kind]
            start = params[P_START_V + kind] if end == 0 else 0.0
            acc = sign * (vw[kind, i] - start) / dts[i]
            e, de = _bound_to_interval(acc, -lim, lim, eps)
            r[row] = w * e
            chi2[family] += r[row] * r[row]
            if jacobian and de != 0.0:
                f = w * de / dts[i]
                _set_segment_cols(cols, i, n)
                cols[6] = 4 * i
                for j in range(6):
                    jac[j] = sign * jvw[kind, i, j] * f
                jac[6] = (sign * jvw[kind, i, 6] - acc) * f
                _accumulate(h, g, cols[:7], jac[:7], r[row])
            row += 1

    # non-holonomic kinematics (both headings make equal angles with the chord), forward drive
    w_nh, w_fd = params[P_W_NH], params[P_W_FD]
    for i in range(n):
        dx, dy = poses[i + 1, 0] - poses[i, 0], poses[i + 1, 1] - poses[i, 1]
        c0, s0, c1, s1 = trig[0, i], trig[1, i], trig[0, i + 1], trig[1, i + 1]
        cs, ss = c0 + c1, s0 + s1
        r_nh = w_nh * (cs * dy - ss * dx)
        proj = dx * c0 + dy * s0
        r_fd = w_fd * max(-proj, 0.0)
        r[row], r[row + n] = r_nh, r_fd
        chi2[F_KIN] += r_nh * r_nh + r_fd * r_fd
        if jacobian:
            _set_segment_cols(cols, i, n)
            jac[0], jac[1], jac[2] = w_nh * ss, -w_nh * cs, -w_nh * (s0 * dy + c0 * dx)
            jac[3], jac[4], jac[5] = -w_nh * ss, w_nh * cs, -w_nh * (s1 * dy + c1 * dx)
            _accumulate(h, g, cols[:6], jac[:6], r_nh)
            if proj < 0.0:
                jac[0], jac[1], jac[2] = w_fd * c0, w_fd * s0, -w_fd * (dy * c0 - dx * s0)
                jac[3], jac[4], jac[5] = -w_fd * c0, -w_fd * s0, 0.0
                _accumulate(h, g, cols[:6], jac[:6], r_fd)
        row += 1
    row += n

    # time optimal
    w = params[P_W_TIME]
    for i in range(n):
        r[row] = w * dts[i]
        chi2[F_TIME] += r[row] * r[row]
        if jacobian:
            cols[0], jac[0] = 4 * i, w
            _accumulate(h, g, cols[:1], jac[:1], r[row])
        row += 1

    # obstacles (+ inflation), both from the same footprint distance; in a gap narrower than the
    # distances ask for, the limits fall to the gap's centre line (see associate_obstacles)
    m = obst_pose.shape[0]
    w_o, w_i, p = params[P_W_OBSTACLE], params[P_W_INFLATION], params[P_EXPONENT]
    inflation = params[P_INFLATION] != 0.0
    for k in range(m):
        pose = obst_pose[k]
        d, gx, gy, gth = footprint_distance_trig(poses[pose, 0], poses[pose, 1], trig[0, pose], trig[1, pose],
                                             obst_point[k, 0], obst_point[k, 1], model)
        e = max(min(params[P_MIN_OBSTACLE], obst_gap[k] - eps) + eps - d, 0.0)
        de = -1.0 if e > 0.0 else 0.0
        if p != 1.0 and e > 0.0:
            de *= p * e ** (p - 1.0)
            e = e ** p
        r[row + k] = w_o * e
        chi2[F_OBSTACLE] += r[row + k] * r[row + k]
        if jacobian and e > 0.0:
            _accumulate_pose(h, g, cols, jac, pose, n, w_o * de, gx, gy, gth, r[row + k])
        if inflation:
            e = max(min(params[P_INFLATION_DIST], obst_gap[k]) - d, 0.0)
            r[row + m + k] = w_i * e
            chi2[F_OBSTACLE] += r[row + m + k] * r[row + m + k]
            if jacobian and e > 0.0:
                _accumulate_pose(h, g, cols, jac, pose, n, -w_i, gx, gy, gth, r[row + m + k])
    row += 2 * m if inflation else m

    # via-points
    nv = via_pose.shape[0]
    w = params[P_W_VIA]
    for k in range(nv):
        c = _pose_col(via_pose[k], n)
        for axis in range(2):
            res = w * (poses[via_pose[k], axis] - via_point[k, axis])
            r[row + axis * nv + k] = res
            chi2[F_VIA] += res * res
            if jacobian:
                cols[0], jac[0] = (c + axis if c >= 0 else -1), w
                _accumulate(h, g, cols[:1], jac[:1], res)
    row += 2 * nv

    # preferred turning direction (oscillation recovery): the first rotations must not turn the
    # other way, error max(0, -s * dtheta) with s = +1 left, -1 right
    w, s = params[P_W_ROTDIR], params[P_ROTDIR]
    if w != 0.0:
        for i in range(min(n, PREFER_ROTDIR_ROTATIONS)):
            e = max(-s * normalize_angle(poses[i + 1, 2] - poses[i, 2]), 0.0)
            r[row] = w * e
            chi2[F_PREFER_ROTDIR] += r[row] * r[row]
            if jacobian and e > 0.0:
                _set_segment_cols(cols, i, n)
                jac[:6] = 0.0
                jac[2], jac[5] = w * s, -w * s
                _accumulate(h, g, cols[:6], jac[:6], r[row])
            row += 1

    # dynamic obstacles (EdgeDynamicObstacle): the footprint distance to the obstacle's centre
    # predicted at the pose's time (fixed when the edges are built), less its radius, kept above
    # min_obstacle_dist and, more softly, above dynamic_obstacle_inflation_dist
    m = dyn_pose.shape[0]
    w_o, w_i = params[P_W_DYNAMIC], params[P_W_DYNAMIC_INFLATION]
    inflation = params[P_DYNAMIC_INFLATION] != 0.0
    for k in range(m):
        pose = dyn_pose[k]
        d, gx, gy, gth = footprint_distance_trig(poses[pose, 0], poses[pose, 1], trig[0, pose], trig[1, pose],
                                                 dyn_obstacle[k, 0], dyn_obstacle[k, 1], model)
        d -= dyn_obstacle[k, 2]
        e = max(params[P_MIN_OBSTACLE] + eps - d, 0.0)
        r[row + k] = w_o * e
        chi2[F_DYNAMIC] += r[row + k] * r[row + k]
        if jacobian and e > 0.0:
            _accumulate_pose(h, g, cols, jac, pose, n, -w_o, gx, gy, gth, r[row + k])
        if inflation:
            e = max(params[P_DYNAMIC_INFLATION_DIST] - d, 0.0)
            r[row + m + k] = w_i * e
            chi2[F_DYNAMIC] += r[row + m + k] * r[row + m + k]
            if jacobian and e > 0.0:
                _accumulate_pose(h, g, cols, jac, pose, n, -w_i, gx, gy, gth, r[row + m + k])
    return chi2.sum()


@njit(cache=True, nogil=True)
def workspace(n, n_res):
    """Outputs (r, chi2, h, g) and scratch of evaluate for a band with n time differences."""
    n_vars = 4 * n - 3
    scratch = (np.empty((2, n)), np.empty((2, n, 7)), np.empty((2, n + 1)), np.empty(16, np.int64), np.empty(16))
    return np.empty(n_res), np.zeros(N_FAMILIES), np.zeros((BANDWIDTH + 1, n_vars)), np.zeros(n_vars), scratch


@njit(cache=True, nogil=True)
def normal_equations(poses, dts, params, edges, model, n_res):
    """Residuals, J^T J (lower bands), J^T r and chi2 of a band: what one inner iteration builds."""
    r, chi2, h, g, work = workspace(dts.shape[0], n_res)
    total = evaluate(poses, dts, params, edges, model, True, r, chi2, h, g, work)
    return r, h, g, total


@njit(cache=True, nogil=True)
def family_chi2(poses, dts, params, edges, model, n_res):
    """chi2 of each edge family, in the order of FAMILIES."""
    r, chi2, h, g, work = workspace(dts.shape[0], n_res)
    evaluate(poses, dts, params, edges, model, False, r, chi2, h, g, work)
    return chi2

