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
    err = np.maximum(lower + eps - value, 0.0)
    return err, -(err > 0.0).astype(float)


@dataclass
class EdgeSet:
    """Edges fixed for one outer iteration (the g2o graph of one buildGraph call), with the column
    layout of every edge family and its scatter indices into the banded normal equations."""
    obst_pose: np.ndarray
    obst_point: np.ndarray
    via_pose: np.ndarray
    via_point: np.ndarray
    obstacle_weight: float
    n: int = 0
    cols: dict = field(default_factory=dict)
    h_index: dict = field(default_factory=dict)
    g_index: dict = field(default_factory=dict)
    bandwidth: int = 0

    @property
    def n_vars(self) -> int:
        return 4 * self.n - 3

    def build_layout(self, free_goal_vel: bool, with_inflation: bool) -> None:
        """Columns of each family's local Jacobian: pose k -> 4k-3..4k-1, dT_i -> 4i, fixed -> -1."""
        n = self.n
        pc = np.full((n + 1, 3), -1, dtype=np.int64)
        pc[1:n] = 4 * np.arange(1, n)[:, None] - 3 + np.arange(3)
        tc = 4 * np.arange(n)[:, None]
        seg = np.hstack([pc[:-1], pc[1:], tc])
        cols = {"vel": seg, "omega": seg}
        for kind in ("acc", "acc_theta"):
            if n >= 2:
                cols[kind] = np.hstack([seg[:-1], seg[1:], tc[:-1], tc[1:]])
            cols[kind + "_start"] = np.hstack([seg[0], tc[0]])[None, :]
            if not free_goal_vel:
                cols[kind + "_goal"] = np.hstack([seg[-1], tc[-1]])[None, :]
        cols["kin_nh"] = cols["kin_fd"] = seg[:, :6]
        cols["time"] = tc
        if len(self.obst_pose):
            cols["obstacle"] = pc[self.obst_pose]
            if with_inflation:
                cols["inflation"] = pc[self.obst_pose]
        if len(self.via_pose):
            cols["via_x"] = pc[self.via_pose, 0:1]
            cols["via_y"] = pc[self.via_pose, 1:2]
        self.cols = cols
        self.bandwidth = max(_row_span(c) for c in cols.values())
        dump = (self.bandwidth + 1) * self.n_vars
        for name, c in cols.items():
            ci, cj = c[:, :, None], c[:, None, :]
            ok = (ci >= cj) & (cj >= 0)
            self.h_index[name] = np.where(ok, (ci - cj) * self.n_vars + cj, dump).ravel()
            self.g_index[name] = np.where(c >= 0, c, self.n_vars).ravel()


def _row_span(cols: np.ndarray) -> int:
    """Largest column distance between two free variables of one edge."""
    big = np.iinfo(np.int64).max
    lo = np.where(cols >= 0, cols, big).min(axis=1)
    hi = cols.max(axis=1)
    ok = hi >= 0
    return int((hi[ok] - lo[ok]).max()) if ok.any() else 0


class TebOptimizer:
    """Optimises one band in place; keeps nothing between calls but the config."""

    def __init__(self, cfg, model):
        self.cfg = cfg
        self.model = model

    # -- outer loop -------------------------------------------------------------------------
    def optimize(self, band: TimedElasticBand, obstacles: np.ndarray, via_points: np.ndarray | None,
                 start_velocity, free_goal_vel: bool, compute_cost: bool = True) -> float:
        """optimizeTEB: outer iterations of autoResize + association + inner LM, the obstacle
        weight growing by weight_adapt_factor. Returns the selection cost of the final graph."""
        cfg = self.cfg
        self.start_velocity = (float(start_velocity[0]), float(start_velocity[1]))
        self.free_goal_vel = free_goal_vel
        multiplier = 1.0
        cost = math.inf
        for outer in range(cfg.no_outer_iterations):
            if cfg.teb_autosize:
                band.auto_resize(cfg.dt_ref, cfg.dt_hysteresis, cfg.min_samples, cfg.max_samples,
                                 fast_mode=not cfg.include_dynamic_obstacles)
            edges = self.build_edges(band, obstacles, via_points, cfg.weight_obstacle * multiplier)
            self.levenberg_marquardt(band, edges, cfg.no_inner_iterations)
            if compute_cost and outer == cfg.no_outer_iterations - 1:
                cost = self.selection_cost(band, edges)
            multiplier *= cfg.weight_adapt_factor
        return cost

    def build_edges(self, band, obstacles, via_points, obstacle_weight) -> EdgeSet:
        cfg = self.cfg
        empty = np.zeros(0, dtype=np.int64)
        if obstacles is not None and len(obstacles) and cfg.weight_obstacle > 0:
            pi, oi = associate_obstacles(self.model, band.poses, obstacles, cfg.min_obstacle_dist,
                                         cfg.obstacle_association_force_inclusion_factor,
                                         cfg.obstacle_association_cutoff_factor)
            obst_point = obstacles[oi]
        else:
            pi, obst_point = empty, np.zeros((0, 2))
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
        edges = EdgeSet(pi, obst_point, vp, vpts, obstacle_weight, n=n - 1)
        edges.build_layout(self.free_goal_vel, self.with_inflation)
        return edges

    @property
    def with_inflation(self) -> bool:
        return self.cfg.inflation_dist > self.cfg.min_obstacle_dist and self.cfg.weight_inflation > 0

    # -- edge evaluation --------------------------------------------------------------------
    def evaluate(self, poses: np.ndarray, dts: np.ndarray, edges: EdgeSet, with_jacobian: bool) -> dict:
        """Weighted residuals per edge family, name -> (r, J_local or None); cost = sum of r.r.
        The local Jacobian columns are edges.cols[name]."""
        cfg = self.cfg
        eps = cfg.penalty_epsilon
        n = len(dts)
        out = {}
        x0, y0, t0 = poses[:-1, 0], poses[:-1, 1], poses[:-1, 2]
        dx, dy = np.diff(poses[:, 0]), np.diff(poses[:, 1])
        cos, sin = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        c0, s0, c1, s1 = cos[:-1], sin[:-1], cos[1:], sin[1:]
        dist = np.hypot(dx, dy)
        proj = dx * c0 + dy * s0
        u = 100.0 * proj
        sig = u / (1.0 + np.abs(u))
        vel = sig * dist / dts
        omega = normalize_theta(np.diff(poses[:, 2])) / dts
        jv = jw = dproj = None
        if with_jacobian:
            inv_dt = 1.0 / dts
            inv = np.divide(1.0, dist, out=np.zeros(n), where=dist > 1e-12)
            dproj = np.empty((n, 6))
            dproj[:, 0], dproj[:, 1], dproj[:, 2] = -c0, -s0, dy * c0 - dx * s0
            dproj[:, 3], dproj[:, 4], dproj[:, 5] = c0, s0, 0.0
            a = (100.0 / (1.0 + np.abs(u)) ** 2 * dist * inv_dt)[:, None]
            b = (sig * inv * inv_dt)
            jv = np.empty((n, 7))
            jv[:, :6] = a * dproj
            jv[:, 0] -= b * dx
            jv[:, 1] -= b * dy
            jv[:, 3] += b * dx
            jv[:, 4] += b * dy
            jv[:, 6] = -vel * inv_dt
            jw = np.zeros((n, 7))
            jw[:, 2] = -inv_dt
            jw[:, 5] = inv_dt
            jw[:, 6] = -omega * inv_dt

        # velocity
        for name, w, val, jac, lo, hi in (
                ("vel", cfg.weight_max_vel_x, vel, jv, -cfg.max_vel_x_backwards, cfg.max_vel_x),
                ("omega", cfg.weight_max_vel_theta, omega, jw, -cfg.max_vel_theta, cfg.max_vel_theta)):
            w = math.sqrt(w)
            e, de = bound_to_interval(val, lo, hi, eps)
            out[name] = (w * e, (w * de)[:, None] * jac if with_jacobian else None)

        # acceleration: interior triples, start (odometry velocity) and goal (zero unless free)
        for name, w, val, jac, lim, start_val in (
                ("acc", cfg.weight_acc_lim_x, vel, jv, cfg.acc_lim_x, self.start_velocity[0]),
                ("acc_theta", cfg.weight_acc_lim_theta, omega, jw, cfg.acc_lim_theta, self.start_velocity[1])):
            w = math.sqrt(w)
            if n >= 2:
                ssum = dts[:-1] + dts[1:]
                acc = 2.0 * (val[1:] - val[:-1]) / ssum
                e, de = bound_to_interval(acc, -lim, lim, eps)
                jac_acc = None
                if with_jacobian:
                    jac_acc = np.empty((n - 1, 16))
                    jac_acc[:, :7] = -2.0 * jac[:-1]
                    jac_acc[:, 7:14] = 2.0 * jac[1:]
                    jac_acc[:, 14] = jac_acc[:, 15] = -acc
                    jac_acc *= (w * de / ssum)[:, None]
                out[name] = (w * e, jac_acc)
            acc0 = (val[0] - start_val) / dts[0]
            e, de = bound_to_interval(acc0, -lim, lim, eps)
            jac0 = (np.append(jac[0], -acc0) * (w * de / dts[0]))[None, :] if with_jacobian else None
            out[name + "_start"] = (np.atleast_1d(w * e), jac0)
            if not self.free_goal_vel:
                accg = -val[-1] / dts[-1]
                e, de = bound_to_interval(accg, -lim, lim, eps)
                jacg = (np.append(-jac[-1], -accg) * (w * de / dts[-1]))[None, :] if with_jacobian else None
                out[name + "_goal"] = (np.atleast_1d(w * e), jacg)

        # non-holonomic kinematics and forward drive
        w = math.sqrt(cfg.weight_kinematics_nh)
        cs, ss = c0 + c1, s0 + s1
        jk = None
        if with_jacobian:
            jk = np.empty((n, 6))
            jk[:, 0], jk[:, 1], jk[:, 2] = ss, -cs, -s0 * dy - c0 * dx
            jk[:, 3], jk[:, 4], jk[:, 5] = -ss, cs, -s1 * dy - c1 * dx
            jk *= w
        out["kin_nh"] = (w * (cs * dy - ss * dx), jk)
        w = math.sqrt(cfg.weight_kinematics_forward_drive)
        e, de = bound_from_below(proj, 0.0, 0.0)
        out["kin_fd"] = (w * e, (w * de)[:, None] * dproj if with_jacobian else None)

        # time optimal
        w = math.sqrt(cfg.weight_optimaltime)
        out["time"] = (w * dts, np.full((n, 1), w) if with_jacobian else None)

        # obstacles (+ inflation)
        if len(edges.obst_pose):
            if with_jacobian:
                d, grad = self.model.distance_and_gradient(poses[edges.obst_pose], edges.obst_point)
            else:
                d = self.model.pair_distances(poses[edges.obst_pose], edges.obst_point)
            w = math.sqrt(edges.obstacle_weight)
            e, de = bound_from_below(d, cfg.min_obstacle_dist, eps)
            p = cfg.obstacle_cost_exponent
            if p != 1.0:
                de = de * p * np.power(e, p - 1.0)
                e = np.power(e, p)
            out["obstacle"] = (w * e, (w * de)[:, None] * grad if with_jacobian else None)
            if self.with_inflation:
                w = math.sqrt(cfg.weight_inflation)
                e, de = bound_from_below(d, cfg.inflation_dist, 0.0)
                out["inflation"] = (w * e, (w * de)[:, None] * grad if with_jacobian else None)

        if len(edges.via_pose):
            w = math.sqrt(cfg.weight_viapoint)
            diff = poses[edges.via_pose, :2] - edges.via_point
            jac = np.full((len(diff), 1), w) if with_jacobian else None
            out["via_x"] = (w * diff[:, 0], jac)
            out["via_y"] = (w * diff[:, 1], jac)
        return out

    @staticmethod
    def chi2(families: dict) -> float:
        return float(sum(r @ r for r, _ in families.values()))

    @staticmethod
    def normal_equations(families: dict, edges: EdgeSet):
        """J^T J in LAPACK lower banded storage (ab[i - j, j] = H[i, j], i >= j) and g = J^T r,
        scattered from the local Jacobians with the precomputed indices (one bincount each)."""
        h_val, g_val, h_idx, g_idx = [], [], [], []
        for name, (res, jac) in families.items():
            h_val.append((jac[:, :, None] * jac[:, None, :]).ravel())
            g_val.append((jac * res[:, None]).ravel())
            h_idx.append(edges.h_index[name])
            g_idx.append(edges.g_index[name])
        size = (edges.bandwidth + 1) * edges.n_vars
        h = np.bincount(np.concatenate(h_idx), np.concatenate(h_val), minlength=size + 1)
        g = np.bincount(np.concatenate(g_idx), np.concatenate(g_val), minlength=edges.n_vars + 1)
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
        for _ in range(iterations):
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
            if not accepted:
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
            if name in ("obstacle", "inflation"):
                chi *= cfg.selection_obst_cost_scale
            elif name in ("via_x", "via_y"):
                chi *= cfg.selection_viapoint_cost_scale
            elif name == "time" and cfg.selection_alternative_time_cost:
                chi = band.sum_of_time_diffs
            cost += chi
        return cost
