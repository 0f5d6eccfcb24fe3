"""amcl's diff and diff-corrected odometry models: the motion they apply and the spread of their samples."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplebot_navigation.geometry import inverse_transform_points, transform_points
from simplebot_navigation.localization.motion_model import noise_sigmas, odometry_steps, sample_motion, wrap

N = 200_000


def sample(delta, alphas, model, start=(0.0, 0.0, 0.0), old_yaw=0.0, seed=0) -> np.ndarray:
    poses = np.tile(np.asarray(start, dtype=float), (N, 1))
    return sample_motion(poses, delta, old_yaw, alphas, model, np.random.default_rng(seed))


@pytest.mark.parametrize("model", ["diff", "diff-corrected"])
def test_without_noise_each_particle_moves_by_the_odometry_change_in_its_own_frame(model):
    old_odom, new_odom = (2.0, -1.0, 0.4), (2.6, -0.7, 1.1)
    delta = (new_odom[0] - old_odom[0], new_odom[1] - old_odom[1], new_odom[2] - old_odom[2])
    particles = np.array([[0.0, 0.0, 0.0], [5.0, 3.0, -2.0], [-1.0, 4.0, 3.0]])
    moved = sample_motion(particles, delta, old_odom[2], (0, 0, 0, 0), model, np.random.default_rng(0))
    step = inverse_transform_points(old_odom, np.array([new_odom]))        # the new odometry pose in the old one
    expected = np.vstack([transform_points(particle, step) for particle in particles])
    np.testing.assert_allclose(moved[:, :2], expected[:, :2], atol=1e-12)
    np.testing.assert_allclose(wrap(moved[:, 2] - expected[:, 2]), 0.0, atol=1e-12)


def test_a_turn_on_the_spot_has_no_first_rotation():
    assert odometry_steps((0.004, -0.005, 0.7), 1.0) == (0.0, math.hypot(0.004, 0.005), pytest.approx(0.7))
    rot1, trans, rot2 = odometry_steps((0.0, 0.5, 0.0), 0.0)
    assert (rot1, trans, rot2) == (pytest.approx(math.pi / 2), 0.5, pytest.approx(-math.pi / 2))


@pytest.mark.parametrize("model", ["diff", "diff-corrected"])
def test_driving_straight_spreads_heading_and_distance_as_the_model_says(model):
    """2 m straight ahead: rot1 = rot2 = 0, so heading noise comes from alpha2 and distance noise from alpha3.
    "diff" takes alpha * trans^2 as the standard deviation, "diff-corrected" its square root."""
    alphas = (0.05, 0.01, 0.02, 0.03)
    trans = 2.0
    sigma_rot = alphas[1] * trans ** 2
    sigma_trans = alphas[2] * trans ** 2
    if model == "diff-corrected":
        sigma_rot, sigma_trans = math.sqrt(sigma_rot), math.sqrt(sigma_trans)
    out = sample((trans, 0.0, 0.0), alphas, model)
    travelled = np.hypot(out[:, 0], out[:, 1])
    heading = np.arctan2(out[:, 1], out[:, 0])           # the noisy first rotation
    second = wrap(out[:, 2] - heading)                   # the noisy second rotation
    assert travelled.mean() == pytest.approx(trans, abs=4 * sigma_trans / math.sqrt(N))
    assert travelled.std() == pytest.approx(sigma_trans, rel=0.01)
    assert heading.mean() == pytest.approx(0.0, abs=4 * sigma_rot / math.sqrt(N))
    assert heading.std() == pytest.approx(sigma_rot, rel=0.01)
    assert second.std() == pytest.approx(sigma_rot, rel=0.01)
    assert np.corrcoef(heading, second)[0, 1] == pytest.approx(0.0, abs=0.01)


@pytest.mark.parametrize("model", ["diff", "diff-corrected"])
def test_turning_on_the_spot_spreads_yaw_from_alpha1_and_position_from_alpha4(model):
    alphas = (0.3, 0.01, 0.02, 0.1)
    turn = 0.8
    sigma_yaw = alphas[0] * turn ** 2
    sigma_shift = alphas[3] * turn ** 2
    if model == "diff-corrected":
        sigma_yaw, sigma_shift = math.sqrt(sigma_yaw), math.sqrt(sigma_shift)
    out = sample((0.0, 0.0, turn), alphas, model, start=(1.0, 2.0, 0.5))
    assert wrap(out[:, 2] - 0.5).mean() == pytest.approx(turn, abs=4 * sigma_yaw / math.sqrt(N))
    assert wrap(out[:, 2] - 0.5).std() == pytest.approx(sigma_yaw, rel=0.01)
    # no first rotation: the position moves along the particle's own heading by the translation noise alone
    along = (out[:, 0] - 1.0) * math.cos(0.5) + (out[:, 1] - 2.0) * math.sin(0.5)
    across = -(out[:, 0] - 1.0) * math.sin(0.5) + (out[:, 1] - 2.0) * math.cos(0.5)
    assert along.std() == pytest.approx(sigma_shift, rel=0.01)
    np.testing.assert_allclose(across, 0.0, atol=1e-12)


def test_backwards_is_no_noisier_than_forwards():
    alphas = (0.2, 0.2, 0.2, 0.2)
    for model in ("diff", "diff-corrected"):
        forward = noise_sigmas(*odometry_steps((0.3, 0.0, 0.1), 0.0), alphas, model)
        backward = noise_sigmas(*odometry_steps((-0.3, 0.0, 0.1), 0.0), alphas, model)
        np.testing.assert_allclose(backward, forward, atol=1e-12)
    backwards = sample((-0.3, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), "diff")
    np.testing.assert_allclose(backwards[0], [-0.3, 0.0, 0.0], atol=1e-12)


def test_the_two_models_differ_only_by_the_square_root():
    steps = odometry_steps((0.4, 0.1, 0.3), 0.2)
    plain = noise_sigmas(*steps, (0.1, 0.2, 0.3, 0.4), "diff")
    corrected = noise_sigmas(*steps, (0.1, 0.2, 0.3, 0.4), "diff-corrected")
    np.testing.assert_allclose(np.square(corrected), plain, rtol=1e-12)
    with pytest.raises(ValueError, match="odom_model_type"):
        noise_sigmas(*steps, (0.1, 0.2, 0.3, 0.4), "omni")
