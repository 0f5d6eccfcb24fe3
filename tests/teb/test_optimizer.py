import numpy as np
import pytest

from simplebot_navigation.teb.band import TimedElasticBand
from simplebot_navigation.teb.config import TebConfig
from simplebot_navigation.teb.footprint import FootprintModel
from simplebot_navigation.teb.optimizer import EdgeSet, RotType, TebOptimizer
from simplebot_navigation.testing.teb_reference import ReferenceEvaluation

from .scenes import LAB_TWO_CIRCLES, straight_plan


def band_from(plan, cfg):
    band = TimedElasticBand()
    band.init_from_path(plan, cfg.robot.max_vel_x, cfg.robot.max_vel_theta, True, cfg.trajectory.min_samples, False)
    return band


def profile(band):
    v = np.hypot(*np.diff(band.poses[:, :2], axis=0).T) / band.time_diffs
    a = 2 * np.diff(v) / (band.time_diffs[:-1] + band.time_diffs[1:])
    a_start = v[0] / band.time_diffs[0]
    a_goal = -v[-1] / band.time_diffs[-1]
    return v, np.concatenate([[a_start], a, [a_goal]])


def test_free_straight_band_with_stiff_limits_cruises_at_max_velocity_within_acc_limits():
    cfg = TebConfig.from_params({"weight_max_vel_x": 100.0, "weight_acc_lim_x": 100.0})
    band = band_from(straight_plan(0.0, 4.0), cfg)
    opt = TebOptimizer(cfg, FootprintModel.point())
    for _ in range(2):
        opt.optimize(band, np.zeros((0, 2)), None, (0.0, 0.0), free_goal_vel=False)
    v, a = profile(band)
    eps = cfg.optim.penalty_epsilon
    cruise = v[len(v) // 2]
    assert cfg.robot.max_vel_x - eps <= cruise <= cfg.robot.max_vel_x
    assert v.max() <= cfg.robot.max_vel_x
    assert np.abs(a).max() <= cfg.robot.acc_lim_x + 0.01
    # the band stays on the straight line, heading along it
    np.testing.assert_allclose(band.poses[:, 1:], 0.0, atol=1e-6)
    # accelerating from rest and braking to the goal both take about max_vel_x / acc_lim_x
    assert band.sum_of_time_diffs == pytest.approx(4.0 / cruise + cruise / cfg.robot.acc_lim_x, rel=0.05)


def test_default_weights_are_soft_the_band_overshoots_and_commands_get_saturated():
    cfg = TebConfig()
    band = band_from(straight_plan(0.0, 4.0), cfg)
    TebOptimizer(cfg, FootprintModel.point()).optimize(band, np.zeros((0, 2)), None, (0.0, 0.0), False)
    v, a = profile(band)
    # teb's weights (max_vel_x 2, acc 1, optimaltime 1) trade a little overshoot for time
    assert cfg.robot.max_vel_x <= v.max() <= cfg.robot.max_vel_x * 1.15
    assert np.abs(a).max() <= cfg.robot.acc_lim_x * 1.3


def test_start_velocity_from_odometry_enters_the_start_acceleration():
    cfg = TebConfig.from_params({"weight_acc_lim_x": 100.0})
    opt = TebOptimizer(cfg, FootprintModel.point())
    band = band_from(straight_plan(0.0, 2.0), cfg)
    opt.optimize(band, np.zeros((0, 2)), None, (0.4, 0.0), False)
    moving_start = profile(band)[0][0]
    band = band_from(straight_plan(0.0, 2.0), cfg)
    opt.optimize(band, np.zeros((0, 2)), None, (0.0, 0.0), False)
    assert moving_start > profile(band)[0][0] + 0.1


@pytest.mark.parametrize("obstacle_y, side", [(0.1, -1), (-0.2, 1)])
def test_band_bends_around_an_obstacle_keeping_min_obstacle_dist(obstacle_y, side):
    cfg = TebConfig()
    model = FootprintModel.from_params(LAB_TWO_CIRCLES)
    obstacle = np.array([[1.5, obstacle_y]])
    band = band_from(straight_plan(0.0, 3.0), cfg)
    opt = TebOptimizer(cfg, model)
    for _ in range(2):
        opt.optimize(band, obstacle, None, (0.0, 0.0), False)
    d = model.distances(band.poses, obstacle)[:, 0]
    assert d.min() >= cfg.obstacles.min_obstacle_dist
    # it passes on the far side of the obstacle, by at least the model's reach + min_obstacle_dist
    passing = band.poses[np.argmin(np.abs(band.poses[:, 0] - 1.5)), 1]
    assert np.sign(passing) == side
    assert abs(passing - obstacle_y) >= 0.2 + cfg.obstacles.min_obstacle_dist


def test_via_points_pull_the_band():
    cfg = TebConfig.from_params({"weight_viapoint": 10.0})
    band = band_from(straight_plan(0.0, 3.0), cfg)
    TebOptimizer(cfg, FootprintModel.point()).optimize(band, np.zeros((0, 2)), np.array([[1.5, 0.5]]),
                                                       (0.0, 0.0), False)
    # a soft pull (against time-optimality and smoothness) from y = 0 most of the way to y = 0.5
    assert band.poses[:, 1].max() > 0.25
    assert np.min(np.hypot(band.poses[:, 0] - 1.5, band.poses[:, 1] - 0.5)) < 0.25


def test_a_via_point_the_robot_has_passed_does_not_pull_the_band_back():
    # Dense via-points (every 0.1 m): the first one can lie beside or behind the robot once it
    # has driven past it. TEB skips a via-point whose nearest band pose is the fixed start.
    cfg = TebConfig.from_params({"weight_viapoint": 50.0})
    band = band_from(straight_plan(0.0, 2.0), cfg)
    TebOptimizer(cfg, FootprintModel.point()).optimize(band, np.zeros((0, 2)), np.array([[-0.1, 0.0], [1.0, 0.0]]),
                                                       (0.2, 0.0), False)
    assert np.all(np.diff(band.poses[:, 0]) > 0), band.poses[:4]


@pytest.mark.parametrize("side", [1, -1])
def test_a_preferred_turning_direction_stops_the_band_from_starting_the_other_way(side):
    # a goal 0.1 m to one side: the band starts with a turn towards it (about 0.06 rad); preferring
    # the other direction, as the oscillation recovery may, its first three rotations go straight
    cfg = TebConfig()
    plan = np.column_stack([np.linspace(0.0, 2.0, 30), np.linspace(0.0, side * 0.1, 30), np.zeros(30)])
    rotations = {}
    for rotdir in (RotType.none, RotType(-side)):
        band = band_from(plan, cfg)
        opt = TebOptimizer(cfg, FootprintModel.from_params(LAB_TWO_CIRCLES))
        opt.prefer_rotdir = rotdir
        for _ in range(3):
            opt.optimize(band, np.zeros((0, 2)), None, (0.0, 0.0), False)
        rotations[rotdir] = side * np.diff(band.poses[:4, 2])
        assert abs(band.poses[-1, 1] - side * 0.1) < 0.01          # the goal is reached either way
    assert rotations[RotType.none][0] > 0.03
    assert np.all(rotations[RotType(-side)] < 1e-3)


@pytest.mark.parametrize("rotdir", list(RotType), ids=[r.name for r in RotType])
@pytest.mark.parametrize("free_goal_vel", [False, True])
@pytest.mark.parametrize("model", [FootprintModel.point(), FootprintModel.circular(0.3),
                                   FootprintModel.from_params(LAB_TWO_CIRCLES),
                                   FootprintModel.polygon([[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]),
                                   FootprintModel.line([-0.3, 0.0], [0.3, 0.0])], ids=lambda m: m.kind)
def test_analytic_jacobian_and_normal_equations_match_finite_differences(model, free_goal_vel, rotdir):
    cfg = TebConfig.from_params({"obstacle_cost_exponent": 1.5, "dynamic_obstacle_inflation_dist": 0.9})
    ref = ReferenceEvaluation(cfg, model, (0.1, 0.05), free_goal_vel, rotdir)
    rng = np.random.default_rng(0)
    n = 8
    poses = np.column_stack([np.linspace(0, 2, n + 1), 0.1 * rng.standard_normal(n + 1),
                             0.3 * rng.standard_normal(n + 1)])
    dts = 0.2 + 0.1 * rng.random(n)
    obstacles = np.array([[1.0, 0.5], [0.6, -0.4], [1.5, 0.3]])
    # two of the edges stand in gaps narrower than min_obstacle_dist (lowered limits)
    # moving obstacles (x, y, radius where predicted): within both distances, one only within the
    # inflation distance, one inside the polygon
    dynamic = np.array([[0.9, 0.6, 0.2], [1.2, -0.9, 0.1], [1.75, 0.05, 0.05]])
    edges = EdgeSet(np.array([2, 3, 4, 5, 3]), obstacles[[0, 0, 1, 2, 1]],
                    np.array([np.inf, 0.3, np.inf, 0.45, np.inf]), np.array([3, 7]),
                    np.array([[1.0, 0.2], [2.0, 0.0]]), 50.0, n=n, dyn_pose=np.array([4, 5, 7]),
                    dyn_obstacle=dynamic, dynamic_weight=80.0)
    layout = ref.layout(edges)
    families = ref.evaluate(poses, dts, edges, True)
    assert np.count_nonzero(families["dynamic_obstacle"][0]) >= 3
    n_vars = 4 * n - 3
    jac, res = [], []
    for name, (r, j) in families.items():
        dense = np.zeros((len(r), n_vars))
        cols = layout.cols[name]
        rows = np.repeat(np.arange(len(r)), cols.shape[1])
        ok = cols.ravel() >= 0
        np.add.at(dense, (rows[ok], cols.ravel()[ok]), j.ravel()[ok])
        jac.append(dense)
        res.append(r)
    jac, res = np.vstack(jac), np.concatenate(res)

    def residuals(step):
        p, t = ref.apply_step(poses, dts, step)
        return np.concatenate([r for r, _ in ref.evaluate(p, t, edges, False).values()])

    h = 1e-6
    numeric = np.column_stack([(residuals(h * e) - residuals(-h * e)) / (2 * h) for e in np.eye(n_vars)])
    np.testing.assert_allclose(jac, numeric, atol=1e-5)
    banded, g = ref.normal_equations(families, layout)
    full = jac.T @ jac
    for k in range(len(banded)):
        np.testing.assert_allclose(banded[k, :n_vars - k], np.diag(full, -k), atol=1e-9)
    assert np.all(np.tril(full, -len(banded)) == 0)
    np.testing.assert_allclose(g, jac.T @ res, atol=1e-9)
