"""Sparse non-linear least squares over the TEB hyper-graph for a diff-drive robot (REFERENCE §4.1).

Every edge family is evaluated for all its instances at once with numpy. The free variables
are packed pose-major, [dT_0, x_1, y_1, th_1, dT_1, ..., x_{n-1}, y_{n-1}, th_{n-1}, dT_{n-1}],
so the normal matrix J^T J is banded; it is accumulated straight from the per-edge local
Jacobians with one bincount into LAPACK banded storage (no sparse-matrix products) and solved
by banded Cholesky, with g2o's Levenberg-Marquardt damping rule. The banded solve also keeps
multi-threaded BLAS out of the loop, which on small dense matrices costs more than it gains.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import LinAlgError, solveh_banded

from simplebot_navigation.teb.band import TimedElasticBand, normalize_theta
from simplebot_navigation.teb.obstacles import associate_obstacles

MIN_TIME_DIFF = 1e-3


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


@dataclass
class EdgeSet:
    """Edges fixed for one outer iteration (the g2o graph of one buildGraph call), with the column
    layout of every edge family and its scatter indices into the banded normal equations."""
    obst_pose: np.ndarray
    obst_point: np.ndarray
    obst_gap: np.ndarray          # clearance of the gap each obstacle edge's pose passes (inf: none)
    via_pose: np.ndarray
    via_point: np.ndarray
    obstacle_weight: float
    n: int = 0
    cols: dict = field(default_factory=dict)
    h_index: dict = field(default_factory=dict)
    g_index: dict = field(default_factory=dict)
    bandwidth: int = 0
    h_all: np.ndarray = None
    g_all: np.ndarray = None

    @property
    def n_vars(self) -> int:
        return 4 * self.n - 3

    def build_layout(self, static: "StaticLayout") -> None:
        """Add the obstacle and via-point families (single-pose edges) to the cached layout of
        the families that depend only on the band size."""
        self.cols, self.h_index, self.g_index = dict(static.cols), dict(static.h_index), dict(static.g_index)
        self.bandwidth = static.bandwidth
        pc = static.pose_cols
        extra = {}
        if len(self.obst_pose):
            obst = pc[self.obst_pose]
            extra["obstacle"] = np.vstack([obst, obst]) if static.with_inflation else obst
        if len(self.via_pose):
            extra["via"] = np.vstack([pc[self.via_pose, 0:1], pc[self.via_pose, 1:2]])
        for name, c in extra.items():
            self.cols[name] = c
            self.h_index[name], self.g_index[name] = _scatter_indices(c, self.n_vars, self.bandwidth)
        self.h_all = np.concatenate([self.h_index[name] for name in self.cols])
        self.g_all = np.concatenate([self.g_index[name] for name in self.cols])


class StaticLayout:
    """Columns of each size-dependent family's local Jacobian: pose k -> 4k-3..4k-1, dT_i -> 4i,
    fixed poses -> -1; plus the scatter indices into banded J^T J."""

    def __init__(self, n: int, free_goal_vel: bool, with_inflation: bool):
        self.with_inflation = with_inflation
        pc = np.full((n + 1, 3), -1, dtype=np.int64)
        pc[1:n] = 4 * np.arange(1, n)[:, None] - 3 + np.arange(3)
        self.pose_cols = pc
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
        self.cols = cols
        # Single-pose families (obstacles, via-points) span 2 columns; keep room for them.
        self.bandwidth = max(2, max(_row_span(c) for c in cols.values()))
        n_vars = 4 * n - 3
        self.h_index, self.g_index = {}, {}
        for name, c in cols.items():
            self.h_index[name], self.g_index[name] = _scatter_indices(c, n_vars, self.bandwidth)


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


class TebOptimizer:
    """Optimises one band in place; keeps only the config and the cached per-size layouts."""

    def __init__(self, cfg, model):
        self.cfg = cfg
        self.model = model
        self._layouts: dict = {}
        # (v, omega) column constants of the stacked velocity and acceleration families
        self._vel_weight = np.sqrt([[cfg.weight_max_vel_x], [cfg.weight_max_vel_theta]])
        self._vel_lower = np.array([[-cfg.max_vel_x_backwards], [-cfg.max_vel_theta]])
        self._vel_upper = np.array([[cfg.max_vel_x], [cfg.max_vel_theta]])
        self._acc_weight = np.sqrt([[cfg.weight_acc_lim_x], [cfg.weight_acc_lim_theta]])
        self._acc_limit = np.array([[cfg.acc_lim_x], [cfg.acc_lim_theta]])

    # -- outer loop -------------------------------------------------------------------------
    def optimize(self, band: TimedElasticBand, obstacles: np.ndarray, via_points: np.ndarray | None,
                 start_velocity, free_goal_vel: bool, compute_cost: bool = True,
                 outer_iterations: int | None = None, skip_outer: int = 0) -> float:
        """optimizeTEB: outer iterations of autoResize + association + inner LM, the obstacle
        weight growing by weight_adapt_factor. skip_outer leaves out the first outer iterations
        (a warm-started band then goes straight to the larger obstacle weights and its cost is
        taken at the same final weight as a full run). Returns the selection cost of the final
        graph (inf unless compute_cost)."""
        cfg = self.cfg
        self.start_velocity = (float(start_velocity[0]), float(start_velocity[1]))
        self.free_goal_vel = free_goal_vel
        multiplier = cfg.weight_adapt_factor ** skip_outer
        cost = math.inf
        outer_iterations = cfg.no_outer_iterations if outer_iterations is None else outer_iterations
        outer_iterations = max(1, outer_iterations - skip_outer)
        for outer in range(outer_iterations):
            if cfg.teb_autosize:
                band.auto_resize(cfg.dt_ref, cfg.dt_hysteresis, cfg.min_samples, cfg.max_samples,
                                 fast_mode=not cfg.include_dynamic_obstacles)
            edges = self.build_edges(band, obstacles, via_points, cfg.weight_obstacle * multiplier)
            self.levenberg_marquardt(band, edges, cfg.no_inner_iterations)
            if compute_cost and outer == outer_iterations - 1:
                cost = self.selection_cost(band, edges)
            multiplier *= cfg.weight_adapt_factor
        return cost

    def build_edges(self, band, obstacles, via_points, obstacle_weight) -> EdgeSet:
        cfg = self.cfg
        empty = np.zeros(0, dtype=np.int64)
        if obstacles is not None and len(obstacles) and cfg.weight_obstacle > 0:
            pi, oi, gap = associate_obstacles(self.model, band.poses, obstacles, cfg.min_obstacle_dist,
                                              cfg.obstacle_association_force_inclusion_factor,
                                              cfg.obstacle_association_cutoff_factor)
            obst_point = obstacles[oi]
        else:
            pi, obst_point, gap = empty, np.zeros((0, 2)), np.zeros(0)
        vp, vpts = empty, np.zeros((0, 2))
        n = len(band.poses)
        if via_points is not None and len(via_points) and cfg.weight_viapoint > 0 and n > 2:
            vpts = np.asarray(via_points, dtype=float).reshape(-1, 2)
            d2 = ((band.poses[None, 1:-1, :2] - vpts[:, None, :]) ** 2).sum(axis=2)
            if cfg.via_points_ordered:
                idx, start = [], 0
                for row in d2:
                    k = start + int(np.argmin(row[start:])) if start < len(row) else len(row) - 1
                    idx.append(k)
                    start = k + 1
                vp = np.array(idx, dtype=np.int64) + 1
            else:
                vp = np.argmin(d2, axis=1) + 1
        edges = EdgeSet(pi, obst_point, gap, vp, vpts, obstacle_weight, n=n - 1)
        key = (n - 1, self.free_goal_vel, self.with_inflation)
        if key not in self._layouts:
            if len(self._layouts) > 64:
                self._layouts.clear()
            self._layouts[key] = StaticLayout(*key)
        edges.build_layout(self._layouts[key])
        return edges

    @property
    def with_inflation(self) -> bool:
        return self.cfg.inflation_dist > self.cfg.min_obstacle_dist and self.cfg.weight_inflation > 0

    # -- edge evaluation --------------------------------------------------------------------
    def evaluate(self, poses: np.ndarray, dts: np.ndarray, edges: EdgeSet, with_jacobian: bool) -> dict:
        """Weighted residuals per edge family, name -> (r, J_local or None); cost = sum of r.r.
        The local Jacobian columns are edges.cols[name]; rows of the two stacked kinds of a
        family follow each other (first all v rows, then all omega rows, ...)."""
        cfg = self.cfg
        eps = cfg.penalty_epsilon
        n = len(dts)
        out = {}
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
        w_nh, w_fd = math.sqrt(cfg.weight_kinematics_nh), math.sqrt(cfg.weight_kinematics_forward_drive)
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
        w = math.sqrt(cfg.weight_optimaltime)
        out["time"] = (w * dts, np.full((n, 1), w) if with_jacobian else None)

        # obstacles (+ inflation), both from the same footprint-model distance
        if len(edges.obst_pose):
            if with_jacobian:
                d, grad = self.model.distance_and_gradient(poses[edges.obst_pose], edges.obst_point)
            else:
                d, grad = self.model.pair_distances(poses[edges.obst_pose], edges.obst_point), None
            # In a gap narrower than the distances ask for, the limits fall to the centre line
            # (associate_obstacles), so passing through costs nothing more than the centring.
            w = math.sqrt(edges.obstacle_weight)
            e, de = bound_from_below(d, np.minimum(cfg.min_obstacle_dist, edges.obst_gap - eps), eps)
            p = cfg.obstacle_cost_exponent
            if p != 1.0:
                de = de * p * np.power(e, p - 1.0)
                e = np.power(e, p)
            res, dres = [w * e], [w * de]
            if self.with_inflation:
                w = math.sqrt(cfg.weight_inflation)
                e, de = bound_from_below(d, np.minimum(cfg.inflation_dist, edges.obst_gap), 0.0)
                res.append(w * e)
                dres.append(w * de)
            out["obstacle"] = (np.concatenate(res),
                               np.concatenate(dres)[:, None] * np.vstack([grad] * len(res)) if with_jacobian else None)

        if len(edges.via_pose):
            w = math.sqrt(cfg.weight_viapoint)
            diff = poses[edges.via_pose, :2] - edges.via_point
            out["via"] = (w * diff.T.ravel(), np.full((2 * len(diff), 1), w) if with_jacobian else None)
        return out

    @staticmethod
    def chi2(families: dict) -> float:
        return float(sum(r @ r for r, _ in families.values()))

    @staticmethod
    def normal_equations(families: dict, edges: EdgeSet):
        """J^T J in LAPACK lower banded storage (ab[i - j, j] = H[i, j], i >= j) and g = J^T r,
        scattered from the local Jacobians with the precomputed indices (one bincount each)."""
        h_val, g_val = [], []
        for name in edges.cols:
            res, jac = families[name]
            h_val.append((jac[:, :, None] * jac[:, None, :]).ravel())
            g_val.append((jac * res[:, None]).ravel())
        size = (edges.bandwidth + 1) * edges.n_vars
        h = np.bincount(edges.h_all, np.concatenate(h_val), minlength=size + 1)
        g = np.bincount(edges.g_all, np.concatenate(g_val), minlength=edges.n_vars + 1)
        return h[:size].reshape(edges.bandwidth + 1, edges.n_vars), g[:edges.n_vars]

    # -- inner loop -----------------------------------------------------------------------
    def levenberg_marquardt(self, band: TimedElasticBand, edges: EdgeSet, iterations: int) -> None:
        """g2o's Levenberg-Marquardt: lambda starts at 1e-5 * max diag(H), shrinks on gain and
        doubles its growth factor on each rejected step (at most 10 trials per iteration)."""
        if edges.n < 1:
            return
        poses, dts = band.poses.copy(), band.time_diffs.copy()
        families = self.evaluate(poses, dts, edges, True)
        chi = self.chi2(families)
        lam = None
        nu = 2.0
        for iteration in range(iterations):
            h, g = self.normal_equations(families, edges)
            if lam is None:
                lam = 1e-5 * float(np.max(h[0]))
            accepted = False
            for _trial in range(10):
                damped = h.copy()
                damped[0] += lam
                try:
                    step = -solveh_banded(damped, g, lower=True, check_finite=False)
                except (LinAlgError, ValueError):
                    lam *= nu
                    nu *= 2.0
                    continue
                new_poses, new_dts = self.apply_step(poses, dts, step)
                new_chi = self.chi2(self.evaluate(new_poses, new_dts, edges, False))
                rho = (chi - new_chi) / (float(step @ (lam * step - g)) + 1e-3)
                if rho > 0 and math.isfinite(new_chi):
                    lam *= max(1.0 / 3.0, min(1.0 - (2.0 * rho - 1.0) ** 3, 2.0 / 3.0))
                    nu = 2.0
                    poses, dts, chi = new_poses, new_dts, new_chi
                    accepted = True
                    break
                lam *= nu
                nu *= 2.0
            if not accepted or iteration == iterations - 1:
                break
            families = self.evaluate(poses, dts, edges, True)
        band.poses, band.time_diffs = poses, dts

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

    def selection_cost(self, band: TimedElasticBand, edges: EdgeSet) -> float:
        """computeCurrentCost: chi2 of all edges, obstacle and via-point edges rescaled for the
        homotopy selection; the total time replaces the time-optimal edges if asked."""
        cfg = self.cfg
        cost = 0.0
        for name, (r, _) in self.evaluate(band.poses, band.time_diffs, edges, False).items():
            chi = float(r @ r)
            if name == "obstacle":
                chi *= cfg.selection_obst_cost_scale
            elif name == "via":
                chi *= cfg.selection_viapoint_cost_scale
            elif name == "time" and cfg.selection_alternative_time_cost:
                chi = band.sum_of_time_diffs
            cost += chi
        return cost
