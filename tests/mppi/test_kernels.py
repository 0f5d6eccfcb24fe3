"""The compiled MPPI kernels against their numpy references (testing/mppi_reference.py).

Both sides do the same arithmetic in the same order, but numba may contract a multiply and an add into one rounding
and its sin/cos may differ from numpy's in the last bit; over 60 integrated steps that stays below 1e-9 m (a
millionth of a costmap cell), the tolerance of every float. Contact indices are compared exactly: random scenes
put no distance within 1e-9 of a threshold.
"""

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.mppi import MppiConfig, kernels
from simplebot_navigation.mppi.body import body_circles, outline_points
from simplebot_navigation.mppi.optimizer import limits_vector
from simplebot_navigation.perception.prediction import MotionPrediction, prediction_rows
from simplebot_navigation.testing import mppi_reference as reference

TOLERANCE = 1e-9
BOX = np.array([[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]])
ROUND = np.column_stack([0.25 * np.cos(np.linspace(0, 2 * np.pi, 16, endpoint=False)),
                         0.25 * np.sin(np.linspace(0, 2 * np.pi, 16, endpoint=False))])


def scene(seed: int, batch: int = 64, steps: int = 40):
    rng = np.random.default_rng(seed)
    cfg = MppiConfig.from_params({"vx_max": 1.0, "wheel_separation": 0.36})
    state = np.array([*rng.uniform(-0.5, 0.5, 2), rng.uniform(-np.pi, np.pi), rng.uniform(-0.2, 1.0),
                      rng.uniform(-1.0, 1.0)])
    sequence = np.column_stack([rng.uniform(0.3, 1.0, steps), rng.uniform(-0.5, 0.5, steps)])
    # rows that ramp to their own target each: rollouts fanned out in speed and turn, wobbling on the way
    targets = rng.uniform([-0.5, -3.0], [1.2, 3.0], (batch, 1, 2))
    noise = targets - sequence + rng.standard_normal((batch, steps, 2)) * [0.3, 1.0]
    return rng, state, sequence, noise, limits_vector(cfg)


@pytest.mark.parametrize("seed", range(4))
def test_rollouts_match_the_reference(seed):
    _, state, sequence, noise, limits = scene(seed)
    compiled = kernels.rollout(state, sequence, noise, limits, 0.05)
    expected = reference.rollout(state, sequence, noise, limits, 0.05)
    for got, want in zip(compiled, expected):
        np.testing.assert_allclose(got, want, atol=TOLERANCE, rtol=0)
    controls = compiled[0]
    wheel = np.abs(controls[..., 0]) + np.abs(controls[..., 1]) * limits[kernels.HALF_SEPARATION]
    assert wheel.max() <= limits[kernels.WHEEL_MAX] + 1e-12          # the drive's saturation holds


@pytest.mark.parametrize("seed", range(4))
def test_the_wheels_ramp_no_faster_than_the_drive(seed):
    """With turn and speed limits above what the wheels can do together (the round body's 9.7 rad/s^2 comes from
    1.75 m/s^2 at the rim), each step's wheel speed change stays within wheel_accel_max x dt, and the rollouts
    match the reference."""
    _, state, sequence, noise, _ = scene(seed)
    cfg = MppiConfig.from_params({"vx_max": 1.0, "wheel_separation": 0.36, "ax_max": 1.5, "az_max": 9.0,
                                  "wz_max": 5.0, "wheel_accel_max": 1.75})
    limits = limits_vector(cfg)
    controls, poses = kernels.rollout(state, sequence, noise, limits, 0.05)
    expected = reference.rollout(state, sequence, noise, limits, 0.05)
    np.testing.assert_allclose(controls, expected[0], atol=TOLERANCE, rtol=0)
    np.testing.assert_allclose(poses, expected[1], atol=TOLERANCE, rtol=0)
    before = np.concatenate([np.broadcast_to(state[3:5], (len(controls), 1, 2)), controls[:, :-1]], axis=1)
    change = np.abs(controls - before)
    wheel_change = change[..., 0] + change[..., 1] * 0.18
    # the wheel speed limit may slow a step further (it scales a velocity down), never speed it up past the ramp
    saturated = np.abs(controls[..., 0]) + np.abs(controls[..., 1]) * 0.18 >= limits[kernels.WHEEL_MAX] - 1e-9
    assert wheel_change[~saturated].max() <= 1.75 * 0.05 + 1e-12
    assert wheel_change[~saturated].max() >= 1.75 * 0.05 - 1e-9        # the ramp binds in these scenes


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("footprint", [BOX, ROUND], ids=["box", "round"])
def test_costmap_terms_match_the_reference(seed, footprint):
    rng, state, sequence, noise, limits = scene(seed)
    values = np.array([0, 40, 128, 252, INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION], dtype=np.uint8)
    grid = rng.choice(values, size=(100, 100), p=[.89, .02, .02, .02, .01, .01, .03])
    grid[46:54, 46:54] = 0                                          # the start is free
    cells = np.hypot(*np.meshgrid(np.arange(100) * 0.05 - 2.475 - state[0], np.arange(100) * 0.05 - 2.475 - state[1]))
    grid[(cells > 0.8) & (cells < 0.85)] = LETHAL_OBSTACLE          # a ring that the faster rollouts reach
    _, poses = kernels.rollout(state, sequence, noise, limits, 0.05)
    args = (poses, grid, -2.5, -2.5, 0.05, outline_points(footprint, 0.05))
    first, mean = kernels.costmap_terms(*args)
    want_first, want_mean = reference.costmap_terms(*args)
    np.testing.assert_array_equal(first, want_first)
    np.testing.assert_allclose(mean, want_mean, atol=TOLERANCE, rtol=0)
    assert (first < poses.shape[1]).any() and (first > 0).any()      # the scenes hold collisions and free poses


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("footprint", [BOX, ROUND], ids=["box", "round"])
def test_moving_terms_match_the_reference(seed, footprint):
    rng, state, sequence, noise, limits = scene(seed)
    _, poses = kernels.rollout(state, sequence, noise, limits, 0.05)
    k = 8
    bearing, distance = rng.uniform(-np.pi, np.pi, k), rng.uniform(3.5, 6.0, k)
    rows = np.column_stack([state[0] + distance * np.cos(bearing), state[1] + distance * np.sin(bearing),
                            rng.uniform(-0.4, 0.4, (k, 2)), rng.uniform(0.1, 0.5, k)])
    heading = np.array([np.cos(state[2]), np.sin(state[2])])
    rows[0] = [*(state[:2] + 2.0 * heading), *(-0.2 * heading), 0.2]      # one coming head-on
    cov = np.zeros((k, 4, 4))
    cov[:, [0, 1, 2, 3], [0, 1, 2, 3]] = rng.uniform(0.0, 0.05, (k, 4))
    obstacles = prediction_rows(rows, cov, 2.0)
    table = MotionPrediction(4.0, 0.1, 0.05).table(obstacles, 0.05, poses.shape[1])
    args = (state[:3], poses, *table, body_circles(footprint), 0.1, 0.05, 0.4)
    first, shortfall = kernels.moving_terms(*args)
    want_first, want_shortfall = reference.moving_terms(*args)
    np.testing.assert_array_equal(first, want_first)
    np.testing.assert_allclose(shortfall, want_shortfall, atol=TOLERANCE, rtol=0)
    assert (first < poses.shape[1]).any() and (first == poses.shape[1]).any()


@pytest.mark.parametrize("seed", range(4))
def test_path_terms_match_the_reference(seed):
    rng, state, sequence, noise, limits = scene(seed)
    controls, poses = kernels.rollout(state, sequence, noise, limits, 0.05)
    path = np.column_stack([np.linspace(0, 3, 31), 0.3 * np.sin(np.linspace(0, 3, 31))])
    args = (poses, controls, state[3:5], 0.05, path, path[-1], np.array([3.0, 0.5, 0.2]))
    np.testing.assert_allclose(kernels.path_terms(*args), reference.path_terms(*args), atol=TOLERANCE, rtol=0)


@pytest.mark.parametrize("seed", range(4))
def test_guide_terms_match_the_reference(seed):
    """A guide that waits, then goes, ending before the rollouts do (held at its end)."""
    rng, state, sequence, noise, limits = scene(seed)
    controls, poses = kernels.rollout(state, sequence, noise, limits, 0.05)
    times = np.linspace(-0.05, 1.5, 16)
    guide = np.column_stack([times, np.maximum(times - 0.5, 0.0) * rng.uniform(0.5, 1.0), 0.2 * np.sin(times)])
    terms = kernels.guide_terms(poses, 0.05, guide)
    np.testing.assert_allclose(terms, reference.guide_terms(poses, 0.05, guide), atol=TOLERANCE, rtol=0)
    assert terms.min() < terms.max()


def test_the_body_is_covered_by_its_circles():
    """Every point of the footprint lies in one of the circles; the round body is one circle of its radius."""
    for footprint in (BOX, ROUND):
        circles = body_circles(footprint)
        points = outline_points(footprint, 0.01) if len(outline_points(footprint, 0.01)) else footprint
        gap = np.hypot(points[:, None, 0] - circles[:, 0], points[:, None, 1] - circles[:, 1]) - circles[:, 2]
        assert (gap.min(axis=1) <= 1e-9).all()
    np.testing.assert_allclose(body_circles(ROUND), [[0.0, 0.0, 0.25]], atol=1e-9)
    assert len(body_circles(BOX)) == 2 and body_circles(BOX)[:, 2].max() < 0.4
