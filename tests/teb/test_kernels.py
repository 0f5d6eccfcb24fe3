"""The compiled TEB kernels against the numpy reference (testing/teb_reference.py)."""

import math

import numpy as np
import pytest

from simplebot_navigation.geometry import normalize_theta
from simplebot_navigation.teb import edge_kernels, footprint_kernels, solver_kernels, warm_up
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.obstacles import FORCE_INCLUSION_SECTORS, GAP_FREE_FRACTION, associate_obstacles
from simplebot_navigation.teb.optimizer import EdgeSet, RotType, TebOptimizer
from simplebot_navigation.testing.teb_reference import ReferenceEvaluation
from simplebot_navigation.testing.teb_reference import associate_obstacles as reference_association

from .scenes import LAB_FOOTPRINT

MODELS = [FootprintModel.point(), FootprintModel.circular(0.3),
          FootprintModel.two_circles(0.2, 0.2, 0.25, 0.15),
          FootprintModel.line([-0.3, 0.05], [0.35, -0.05]),
          FootprintModel.polygon(LAB_FOOTPRINT.tolist())]
IDS = [m.kind for m in MODELS]


def random_band(rng, n):
    """A wobbly band along x with random headings (some backwards, some wrapped past pi)."""
    poses = np.column_stack([np.cumsum(0.1 + 0.2 * rng.random(n + 1)), 0.3 * rng.standard_normal(n + 1),
                             rng.uniform(-math.pi, math.pi, n + 1) * (rng.random(n + 1) < 0.3)
                             + 0.3 * rng.standard_normal(n + 1)])
    dts = 0.05 + 0.5 * rng.random(n)
    return poses, dts


def random_edges(rng, poses, n, weight):
    m = int(rng.integers(0, 12))
    obst_pose = rng.integers(1, n, m) if n > 1 else np.zeros(0, np.int64)
    # points around their poses, some inside the footprint, some gaps narrower than the limits
    obst_point = poses[obst_pose, :2] + rng.uniform(-0.9, 0.9, (len(obst_pose), 2))
    gap = np.where(rng.random(len(obst_pose)) < 0.4, rng.uniform(0.1, 0.7, len(obst_pose)), np.inf)
    n_via = int(rng.integers(0, 4)) if n > 1 else 0
    via_pose = rng.integers(1, n, n_via)
    via_point = poses[via_pose, :2] + rng.uniform(-0.5, 0.5, (n_via, 2))
    # moving obstacles predicted near their poses, some overlapping the footprint
    m_dyn = int(rng.integers(0, 10)) if n > 1 else 0
    dyn_pose = rng.integers(1, n, m_dyn) if n > 1 else np.zeros(0, np.int64)
    dyn_obstacle = np.column_stack([poses[dyn_pose, :2] + rng.uniform(-1.2, 1.2, (m_dyn, 2)),
                                    rng.uniform(0.0, 0.5, m_dyn)])
    return EdgeSet(obst_pose, obst_point, gap, via_pose, via_point, weight, n=n, dyn_pose=dyn_pose,
                   dyn_obstacle=dyn_obstacle, dynamic_weight=weight * rng.uniform(0.2, 2.0))


def dense_lower(banded, n_vars):
    full = np.zeros((n_vars, n_vars))
    for k in range(min(len(banded), n_vars)):
        idx = np.arange(n_vars - k)
        full[idx + k, idx] = banded[k, :n_vars - k]
    return full


@pytest.mark.parametrize("model", MODELS, ids=IDS)
@pytest.mark.parametrize("free_goal_vel", [False, True])
@pytest.mark.parametrize("inflation", [False, True])
@pytest.mark.parametrize("rotdir", list(RotType), ids=[r.name for r in RotType])
def test_compiled_evaluation_and_normal_equations_match_the_reference(model, free_goal_vel, inflation, rotdir):
    rng = np.random.default_rng([len(model.kind), free_goal_vel, inflation, rotdir + 1])
    for trial in range(12):
        cfg = TebConfig.from_params({"obstacle_cost_exponent": [1.0, 1.7, 2.0][trial % 3],
                                     "inflation_dist": 0.8 if inflation else 0.4,
                                     "dynamic_obstacle_inflation_dist": [0.9, 0.3][(trial + inflation) % 2],
                                     "weight_viapoint": 3.0, "max_vel_x_backwards": 0.15,
                                     "weight_prefer_rotdir": [50.0, 7.0, 0.0][trial % 3]})
        n = int(rng.integers(1, 30))
        poses, dts = random_band(rng, n)
        start_velocity = tuple(rng.uniform(-0.5, 0.5, 2))
        edges = random_edges(rng, poses, n, 50.0 * 2 ** trial)
        ref = ReferenceEvaluation(cfg, model, start_velocity, free_goal_vel, rotdir)
        families = ref.evaluate(poses, dts, edges, True)
        layout = ref.layout(edges)
        h_ref, g_ref = ref.normal_equations(families, layout)
        r_ref = np.concatenate([r for r, _ in families.values()])

        opt = TebOptimizer(cfg, model)
        opt.start_velocity, opt.free_goal_vel, opt.prefer_rotdir = start_velocity, free_goal_vel, rotdir
        params = opt.parameters(edges)
        r, h, g, chi2 = edge_kernels.normal_equations(poses, dts, params, edges.arrays, model.kernel_model,
                                                 opt.residual_count(edges, params))
        np.testing.assert_allclose(r, r_ref, rtol=1e-9, atol=1e-9)
        scale = max(1.0, np.abs(h_ref).max())
        n_vars = 4 * n - 3
        np.testing.assert_allclose(dense_lower(h, n_vars), dense_lower(h_ref, n_vars), rtol=1e-9, atol=1e-9 * scale)
        np.testing.assert_allclose(g, g_ref, rtol=1e-9, atol=1e-9 * scale)
        assert chi2 == pytest.approx(ref.chi2(families), rel=1e-9, abs=1e-9)
        per_family = edge_kernels.family_chi2(poses, dts, params, edges.arrays, model.kernel_model, len(r))
        expected = [float(families[f][0] @ families[f][0]) if f in families else 0.0 for f in edge_kernels.FAMILIES]
        np.testing.assert_allclose(per_family, expected, rtol=1e-9, atol=1e-9)
        # the random headings turn both ways in the first rotations, so a preference costs something
        turns_away = rotdir * normalize_theta(np.diff(poses[:4, 2])) < 0
        if rotdir != RotType.none and cfg.optim.weight_prefer_rotdir > 0 and turns_away[:n].any():
            assert per_family[edge_kernels.F_PREFER_ROTDIR] > 0


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_footprint_distance_and_gradient_match_the_model(model):
    rng = np.random.default_rng(1)
    poses = np.column_stack([rng.uniform(-1, 1, (200, 2)), rng.uniform(-math.pi, math.pi, 200)])
    points = poses[:, :2] + rng.uniform(-0.8, 0.8, (200, 2))
    d_ref, grad_ref = model.distance_and_gradient(poses, points)
    got = np.array([footprint_kernels.footprint_distance(*p, *q, model.kernel_model) for p, q in zip(poses, points)])
    np.testing.assert_allclose(got[:, 0], d_ref, atol=1e-12)
    np.testing.assert_allclose(got[:, 1:], grad_ref, atol=1e-12)


@pytest.mark.parametrize("model", MODELS, ids=IDS)
def test_compiled_association_matches_the_reference(model):
    rng = np.random.default_rng(2)
    for trial in range(10):
        n = int(rng.integers(2, 25))
        poses, _ = random_band(rng, n)
        obstacles = np.column_stack([rng.uniform(-1, poses[-1, 0] + 1, 150), rng.uniform(-2.5, 2.5, 150)])
        # a door: two jambs either side of the band
        obstacles = np.vstack([obstacles, [[poses[n // 2, 0], 0.55]], [[poses[n // 2, 0], -0.6]]])
        args = (model, poses, obstacles, 0.5, 1.5, [5.0, 1.2][trial % 2])
        got = associate_obstacles(*args)
        expected = reference_association(*args, FORCE_INCLUSION_SECTORS, GAP_FREE_FRACTION)
        for a, b in zip(got, expected):
            np.testing.assert_array_equal(a, b)


def test_banded_cholesky_solves_a_banded_system():
    rng = np.random.default_rng(3)
    size, bw = 40, edge_kernels.BANDWIDTH
    full = np.zeros((size, size))
    for i in range(size):                                  # a banded J^T J, plus damping
        row = np.zeros(size)
        row[i:i + bw + 1] = rng.standard_normal(min(bw + 1, size - i))
        full += np.outer(row, row)
    full += 1e-3 * np.eye(size)
    banded = np.array([np.concatenate([np.diag(full, -k), np.zeros(k)]) for k in range(bw + 1)])
    b = rng.standard_normal(size)
    x = np.empty(size)
    assert solver_kernels.banded_cholesky(banded)
    solver_kernels.banded_solve(banded, b, x)
    np.testing.assert_allclose(full @ x, b, atol=1e-9)
    indefinite = np.zeros((bw + 1, size))
    indefinite[0] = -1.0
    assert not solver_kernels.banded_cholesky(indefinite)


def test_levenberg_marquardt_never_raises_the_cost():
    rng = np.random.default_rng(4)
    cfg = TebConfig()
    model = MODELS[2]
    for _ in range(10):
        n = int(rng.integers(2, 30))
        poses, dts = random_band(rng, n)
        edges = random_edges(rng, poses, n, 100.0)
        opt = TebOptimizer(cfg, model)
        params = opt.parameters(edges)
        count = opt.residual_count(edges, params)
        before = edge_kernels.family_chi2(poses, dts, params, edges.arrays, model.kernel_model, count).sum()
        after = solver_kernels.levenberg_marquardt(poses, dts, params, edges.arrays, model.kernel_model, count, 5)
        assert after <= before
        assert after == pytest.approx(edge_kernels.family_chi2(poses, dts, params, edges.arrays, model.kernel_model,
                                                          count).sum())
        assert np.all(dts >= edge_kernels.MIN_TIME_DIFF) and np.all(np.abs(poses[:, 2]) <= math.pi)


def test_warm_up_leaves_the_cycle_kernels_compiled():
    warm_up()
    for kernel in (footprint_kernels.associate_obstacles, solver_kernels.levenberg_marquardt, edge_kernels.family_chi2):
        assert kernel.signatures
