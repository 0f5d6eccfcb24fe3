"""Vectorised numpy evaluation of the TEB hyper-graph and obstacle association: the readable oracle
the compiled kernels (teb/edge_kernels.py) are tested against, and the baseline bench/teb.py times them
against. The planner itself does not use it.

Every edge family is evaluated for all its instances at once. Variables are packed as in
teb/edge_kernels.py; the normal matrix J^T J is accumulated from the per-edge local Jacobians with one
bincount into LAPACK lower banded storage (ab[i - j, j] = H[i, j]).
"""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.teb.edge_kernels import MIN_TIME_DIFF, PREFER_ROTDIR_ROTATIONS, with_dynamic_inflation


def bound_to_interval(value, lower, upper, eps):
    """Penalty and its derivative: zero inside [lower+eps, upper-eps], linear excess outside."""
    lo, hi = lower + eps, upper - eps
    err = np.maximum(lo - value, 0.0) + np.maximum(value - hi, 0.0)
    derr = (value > hi).astype(float) - (value < lo)
    return err, derr


def bound_from_below(value, lower, eps):
    """Penalty and its derivative: zero above lower+eps, linear shortfall below."""
    err = np.maximum(lower + eps - value, 0.0)
    return err, -(err > 0.0).astype(float)


class Layout:
    """Columns of each family's local Jacobian: pose k -> 4k-3..4k-1, dT_i -> 4i, fixed poses -> -1;
    plus the scatter indices of every (i, j) product into banded J^T J."""

    def __init__(self, edges, free_goal_vel: bool, with_inflation: bool, prefer_rotdir: bool = False,
                 dynamic_inflation: bool = False):
        n = edges.n
        self.n_vars = 4 * n - 3
        pc = np.full((n + 1, 3), -1, dtype=np.int64)
        pc[1:n] = 4 * np.arange(1, n)[:, None] - 3 + np.arange(3)
        tc = 4 * np.arange(n)[:, None]
        seg = np.hstack([pc[:-1], pc[1:], tc])
        # Families stack their two residual kinds (v and omega, nh and forward drive, ...) so
        # each numpy operation covers both.
        cols = {"vel": np.vstack([seg, seg])}
        if n >= 2:
            acc = np.hstack([seg[:-1], seg[1:], tc[:-1], tc[1:]])
            cols["acc"] = np.vstack([acc, acc])
        cols["acc_start"] = np.repeat(np.hstack([seg[0], tc[0]])[None, :], 2, axis=0)
        if not free_goal_vel:
            cols["acc_goal"] = np.repeat(np.hstack([seg[-1], tc[-1]])[None, :], 2, axis=0)
        cols["kin"] = np.vstack([seg[:, :6], seg[:, :6]])
        cols["time"] = tc
        if len(edges.obst_pose):
            obst = pc[edges.obst_pose]
            cols["obstacle"] = np.vstack([obst, obst]) if with_inflation else obst
        if len(edges.via_pose):
            cols["via"] = np.vstack([pc[edges.via_pose, 0:1], pc[edges.via_pose, 1:2]])
        if prefer_rotdir:
            cols["prefer_rotdir"] = seg[:PREFER_ROTDIR_ROTATIONS, :6]
        if len(edges.dyn_pose):
            dyn = pc[edges.dyn_pose]
            cols["dynamic_obstacle"] = np.vstack([dyn, dyn]) if dynamic_inflation else dyn
        self.cols = cols
        self.bandwidth = max(_row_span(c) for c in cols.values())
        h, g = zip(*(_scatter_indices(c, self.n_vars, self.bandwidth) for c in cols.values()))
        self.h_all, self.g_all = np.concatenate(h), np.concatenate(g)


def _scatter_indices(cols: np.ndarray, n_vars: int, bandwidth: int):
    """Flat indices of every (i, j) product of a row into lower banded storage, and of every
    column into g; pairs above the diagonal or with a fixed variable go to a dump slot."""
    ci, cj = cols[:, :, None], cols[:, None, :]
    ok = (ci >= cj) & (cj >= 0)
    h = np.where(ok, (ci - cj) * n_vars + cj, (bandwidth + 1) * n_vars).ravel()
    g = np.where(cols >= 0, cols, n_vars).ravel()
    return h, g


def _row_span(cols: np.ndarray) -> int:
    """Largest column distance between two free variables of one edge."""
    big = np.iinfo(np.int64).max
    lo = np.where(cols >= 0, cols, big).min(axis=1)
    hi = cols.max(axis=1)
    ok = hi >= 0
    return int((hi[ok] - lo[ok]).max()) if ok.any() else 0


class ReferenceEvaluation:
    """The edges of one band (TebOptimizer's EdgeSet) evaluated with numpy."""

    def __init__(self, cfg, model, start_velocity, free_goal_vel: bool, rotdir: int = 0):
        """rotdir: preferred turning direction, +1 left, -1 right, 0 none."""
        self.cfg = cfg
        self.rotdir = rotdir
        self.prefer_rotdir = rotdir != 0 and cfg.optim.weight_prefer_rotdir > 0
        self.model = model
        self.start_velocity = (float(start_velocity[0]), float(start_velocity[1]))
        self.free_goal_vel = free_goal_vel
        robot, obstacles, optim = cfg.robot, cfg.obstacles, cfg.optim
        self.with_inflation = obstacles.inflation_dist > obstacles.min_obstacle_dist and optim.weight_inflation > 0
        self.dynamic_inflation = with_dynamic_inflation(cfg)
        # (v, omega) column constants of the stacked velocity and acceleration families
        self._vel_weight = np.sqrt([[optim.weight_max_vel_x], [optim.weight_max_vel_theta]])
        self._vel_lower = np.array([[-robot.max_vel_x_backwards], [-robot.max_vel_theta]])
        self._vel_upper = np.array([[robot.max_vel_x], [robot.max_vel_theta]])
        self._acc_weight = np.sqrt([[optim.weight_acc_lim_x], [optim.weight_acc_lim_theta]])
        self._acc_limit = np.array([[robot.acc_lim_x], [robot.acc_lim_theta]])

    def layout(self, edges) -> Layout:
        return Layout(edges, self.free_goal_vel, self.with_inflation, self.prefer_rotdir, self.dynamic_inflation)

    def evaluate(self, poses: np.ndarray, dts: np.ndarray, edges, with_jacobian: bool) -> dict:
        """Weighted residuals per edge family, name -> (r, J_local or None), in the order of
        edge_kernels.FAMILIES; cost = sum of r.r. The local Jacobian columns are Layout.cols[name]; rows
        of the two stacked kinds of a family follow each other (all v rows, then all omega rows)."""
        cfg = self.cfg
        eps = cfg.optim.penalty_epsilon
        n = len(dts)
        out = {}
        vw, jvw, dproj, (proj, dx, dy, c0, s0, c1, s1) = self._segments(poses, dts, with_jacobian)

        # velocity
        w, lo, hi = self._vel_weight, self._vel_lower, self._vel_upper
        e, de = bound_to_interval(vw, lo, hi, eps)
        out["vel"] = ((w * e).ravel(), ((w * de)[..., None] * jvw).reshape(2 * n, 7) if with_jacobian else None)

        # acceleration: interior triples, start (odometry velocity) and goal (zero unless free)
        w, lim = self._acc_weight, self._acc_limit
        if n >= 2:
            ssum = dts[:-1] + dts[1:]
            acc = 2.0 * (vw[:, 1:] - vw[:, :-1]) / ssum
            e, de = bound_to_interval(acc, -lim, lim, eps)
            jac = None
            if with_jacobian:
                jac = np.empty((2, n - 1, 16))
                jac[..., :7] = -2.0 * jvw[:, :-1]
                jac[..., 7:14] = 2.0 * jvw[:, 1:]
                jac[..., 14] = jac[..., 15] = -acc
                jac = (jac * (w * de / ssum)[..., None]).reshape(2 * (n - 1), 16)
            out["acc"] = ((w * e).ravel(), jac)
        start = np.array([[self.start_velocity[0]], [self.start_velocity[1]]])
        ends = [("acc_start", 0, vw[:, :1] - start, 1.0)]
        if not self.free_goal_vel:
            ends.append(("acc_goal", n - 1, -vw[:, -1:], -1.0))
        for name, i, delta, sign in ends:
            acc = delta / dts[i]                                   # (2, 1)
            e, de = bound_to_interval(acc, -lim, lim, eps)
            jac = None
            if with_jacobian:
                jac = np.empty((2, 8))
                jac[:, :7] = sign * jvw[:, i]
                jac[:, 7] = -acc[:, 0]
                jac *= w * de / dts[i]
            out[name] = ((w * e).ravel(), jac)

        # non-holonomic kinematics and forward drive
        w_nh, w_fd = math.sqrt(cfg.optim.weight_kinematics_nh), math.sqrt(cfg.optim.weight_kinematics_forward_drive)
        cs, ss = c0 + c1, s0 + s1
        e_fd, de_fd = bound_from_below(proj, 0.0, 0.0)
        jac = None
        if with_jacobian:
            jac = np.empty((2 * n, 6))
            jk = jac[:n]
            jk[:, 0], jk[:, 1], jk[:, 2] = ss, -cs, -s0 * dy - c0 * dx
            jk[:, 3], jk[:, 4], jk[:, 5] = -ss, cs, -s1 * dy - c1 * dx
            jk *= w_nh
            jac[n:] = (w_fd * de_fd)[:, None] * dproj
        out["kin"] = (np.concatenate([w_nh * (cs * dy - ss * dx), w_fd * e_fd]), jac)

        # time optimal
        w = math.sqrt(cfg.optim.weight_optimaltime)
        out["time"] = (w * dts, np.full((n, 1), w) if with_jacobian else None)

        self._placement_families(out, poses, edges, n, with_jacobian)
        return out

    @staticmethod
    def _segments(poses: np.ndarray, dts: np.ndarray, with_jacobian: bool):
        """Per segment: [v; omega], their Jacobians (2, n, 7) and the projection's (n, 6) when asked, and
        (projection on the heading, dx, dy, cos/sin at both ends)."""
        n = len(dts)
        dx, dy = np.diff(poses[:, 0]), np.diff(poses[:, 1])
        cos, sin = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        c0, s0, c1, s1 = cos[:-1], sin[:-1], cos[1:], sin[1:]
        dist = np.hypot(dx, dy)
        proj = dx * c0 + dy * s0
        u = 100.0 * proj
        sig = u / (1.0 + np.abs(u))
        inv_dt = 1.0 / dts
        vw = np.empty((2, n))                                   # [v; omega] per segment
        vw[0] = sig * dist * inv_dt
        vw[1] = normalize_theta(np.diff(poses[:, 2])) * inv_dt
        jvw = dproj = None
        if with_jacobian:
            inv = np.divide(1.0, dist, out=np.zeros(n), where=dist > 1e-12)
            dproj = np.empty((n, 6))
            dproj[:, 0], dproj[:, 1], dproj[:, 2] = -c0, -s0, dy * c0 - dx * s0
            dproj[:, 3], dproj[:, 4], dproj[:, 5] = c0, s0, 0.0
            a = (100.0 / (1.0 + np.abs(u)) ** 2 * dist * inv_dt)[:, None]
            b = sig * inv * inv_dt
            jvw = np.zeros((2, n, 7))
            jv, jw = jvw[0], jvw[1]
            jv[:, :6] = a * dproj
            jv[:, 0] -= b * dx
            jv[:, 1] -= b * dy
            jv[:, 3] += b * dx
            jv[:, 4] += b * dy
            jv[:, 6] = -vw[0] * inv_dt
            jw[:, 2] = -inv_dt
            jw[:, 5] = inv_dt
            jw[:, 6] = -vw[1] * inv_dt
        return vw, jvw, dproj, (proj, dx, dy, c0, s0, c1, s1)

    def _placement_families(self, out: dict, poses: np.ndarray, edges, n: int, with_jacobian: bool) -> None:
        """The families that depend on where the poses are: obstacles, via-points, the preferred turn,
        dynamic obstacles."""
        cfg = self.cfg
        eps = cfg.optim.penalty_epsilon
        # obstacles (+ inflation), both from the same footprint-model distance; in a gap narrower than
        # the distances ask for, the limits fall to the centre line (associate_obstacles), so passing
        # through costs nothing more than the centring
        if len(edges.obst_pose):
            d, grad = self._distances(poses[edges.obst_pose], edges.obst_point, with_jacobian)
            inflation = ((cfg.optim.weight_inflation, np.minimum(cfg.obstacles.inflation_dist, edges.obst_gap))
                         if self.with_inflation else None)
            out["obstacle"] = _distance_family(d, grad, edges.obstacle_weight,
                                               np.minimum(cfg.obstacles.min_obstacle_dist, edges.obst_gap - eps), eps,
                                               cfg.optim.obstacle_cost_exponent, inflation)

        if len(edges.via_pose):
            w = math.sqrt(self.cfg.optim.weight_viapoint)
            diff = poses[edges.via_pose, :2] - edges.via_point
            out["via"] = (w * diff.T.ravel(), np.full((2 * len(diff), 1), w) if with_jacobian else None)

        # preferred turning direction: the first rotations must not turn the other way
        if self.prefer_rotdir:
            w = math.sqrt(cfg.optim.weight_prefer_rotdir)
            k = min(n, PREFER_ROTDIR_ROTATIONS)
            e, de = bound_from_below(self.rotdir * normalize_theta(np.diff(poses[:k + 1, 2])), 0.0, 0.0)
            jac = None
            if with_jacobian:
                jac = np.zeros((k, 6))
                jac[:, 2], jac[:, 5] = -w * de * self.rotdir, w * de * self.rotdir
            out["prefer_rotdir"] = (w * e, jac)

        # dynamic obstacles at their predicted centres, less their radius
        if len(edges.dyn_pose):
            d, grad = self._distances(poses[edges.dyn_pose], edges.dyn_obstacle[:, :2], with_jacobian)
            inflation = ((cfg.optim.weight_dynamic_obstacle_inflation, cfg.obstacles.dynamic_obstacle_inflation_dist)
                         if self.dynamic_inflation else None)
            out["dynamic_obstacle"] = _distance_family(d - edges.dyn_obstacle[:, 2], grad, edges.dynamic_weight,
                                                       cfg.obstacles.min_obstacle_dist, eps, 1.0, inflation)

    def _distances(self, poses: np.ndarray, points: np.ndarray, with_jacobian: bool):
        """Footprint-model distance of each pose to its point, and its pose gradient when asked."""
        if with_jacobian:
            return self.model.distance_and_gradient(poses, points)
        return self.model.pair_distances(poses, points), None

    @staticmethod
    def chi2(families: dict) -> float:
        return float(sum(r @ r for r, _ in families.values()))

    @staticmethod
    def normal_equations(families: dict, layout: Layout):
        """J^T J in lower banded storage and g = J^T r, scattered from the local Jacobians with the
        precomputed indices (one bincount each)."""
        h_val, g_val = [], []
        for name in layout.cols:
            res, jac = families[name]
            h_val.append((jac[:, :, None] * jac[:, None, :]).ravel())
            g_val.append((jac * res[:, None]).ravel())
        size = (layout.bandwidth + 1) * layout.n_vars
        h = np.bincount(layout.h_all, np.concatenate(h_val), minlength=size + 1)
        g = np.bincount(layout.g_all, np.concatenate(g_val), minlength=layout.n_vars + 1)
        return h[:size].reshape(layout.bandwidth + 1, layout.n_vars), g[:layout.n_vars]

    @staticmethod
    def apply_step(poses, dts, step):
        n = len(dts)
        new_poses = poses.copy()
        new_dts = np.maximum(dts + step[0::4], MIN_TIME_DIFF)
        if n > 1:
            grouped = step[1:].reshape(n - 1, 4)
            new_poses[1:n] += grouped[:, :3]
            new_poses[1:n, 2] = normalize_theta(new_poses[1:n, 2])
        return new_poses, new_dts


def _distance_family(d, grad, weight, lower, eps, exponent, inflation):
    """(residuals, Jacobian or None) of distances kept above lower (+eps), the error raised to
    exponent, and with inflation = (weight, distance) a second, softer bound stacked below."""
    w = math.sqrt(weight)
    e, de = bound_from_below(d, lower, eps)
    if exponent != 1.0:
        de = de * exponent * np.power(e, exponent - 1.0)
        e = np.power(e, exponent)
    res, dres = [w * e], [w * de]
    if inflation is not None:
        w = math.sqrt(inflation[0])
        e, de = bound_from_below(d, inflation[1], 0.0)
        res.append(w * e)
        dres.append(w * de)
    return np.concatenate(res), np.concatenate(dres)[:, None] * np.vstack([grad] * len(res)) if grad is not None else None


def associate_obstacles(model, poses: np.ndarray, obstacles: np.ndarray, min_obstacle_dist: float,
                        force_inclusion_factor: float, cutoff_factor: float, sectors: int,
                        gap_free_fraction: float):
    """obstacles.associate_obstacles with numpy: the same pairs in the same order."""
    n_int = len(poses) - 2
    empty = np.zeros(0, dtype=np.int64)
    if n_int <= 0 or len(obstacles) == 0:
        return empty, empty, np.zeros(0)
    inner = poses[1:-1]
    cutoff = min_obstacle_dist * cutoff_factor
    # Cheap centre-distance prefilter: a model point is never farther than its bounding radius.
    rel = obstacles[None, :, :] - inner[:, None, :2]
    centre_d2 = np.einsum("nmj,nmj->nm", rel, rel)
    reach = cutoff + model.bounding_radius
    keep = np.nonzero((centre_d2 <= reach * reach).any(axis=0))[0]
    if len(keep) == 0:
        return empty, empty, np.zeros(0)
    rel = rel[:, keep]
    dist = model.distances(inner, obstacles[keep])                            # n_int, K
    force = dist < min_obstacle_dist * force_inclusion_factor
    candidate = ~force & (dist <= cutoff)
    cross = np.cos(inner[:, 2])[:, None] * rel[..., 1] - np.sin(inner[:, 2])[:, None] * rel[..., 0]
    rows = np.arange(n_int)
    pose_idx, obst_idx = [], []
    picks = [np.where(candidate & side, dist, np.inf) for side in (cross > 0, cross <= 0)]
    sector = np.floor((np.arctan2(rel[..., 1], rel[..., 0]) + math.pi)
                      * (sectors / (2 * math.pi))).astype(np.int64) % sectors
    picks += [np.where(force & (sector == k), dist, np.inf) for k in range(sectors)]
    for d_pick in picks:
        j = np.argmin(d_pick, axis=1)
        ok = np.isfinite(d_pick[rows, j])
        pose_idx.append(rows[ok])
        obst_idx.append(j[ok])
    gap = _gap_clearance(model, inner, obstacles[keep], dist, cross, gap_free_fraction)
    pose_idx = np.concatenate(pose_idx)
    return pose_idx + 1, keep[np.concatenate(obst_idx)], gap[pose_idx]


def _gap_clearance(model, inner, points, dist, cross, gap_free_fraction) -> np.ndarray:
    rows = np.arange(len(inner))
    left = np.argmin(np.where(cross > 0, dist, np.inf), axis=1)
    right = np.argmin(np.where(cross <= 0, dist, np.inf), axis=1)
    both = np.isfinite(dist[rows, left]) & (cross[rows, left] > 0) & (cross[rows, right] <= 0)
    a, b = points[left], points[right]
    mid = 0.5 * (a + b)
    half = 0.5 * np.hypot(*(b - a).T)
    to_mid = np.sqrt(((points[None, :, :] - mid[:, None, :]) ** 2).sum(axis=2)).min(axis=1)
    centred = np.column_stack([mid, inner[:, 2]])
    clearance = np.minimum(model.pair_distances(centred, a), model.pair_distances(centred, b))
    passable = (half > model.inscribed_radius) & (clearance > 0)
    return np.where(both & (to_mid >= gap_free_fraction * half) & passable, clearance, np.inf)
