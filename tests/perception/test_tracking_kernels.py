"""The compiled tracker kernels agree with their array forms (kalman.py, segmentation.fit_circles and
segment_reference)."""

import numpy as np
import pytest

from simplebot_navigation.perception import kalman, tracking_kernels
from simplebot_navigation.perception.segmentation import (FIT_DAMPING, FIT_ITERATIONS, FIXED_INFORMATION, Clusters,
                                                          fit_circles, segment, segment_reference)
from simplebot_navigation.testing.lidar_scenes import Cylinder, scans_at


def _random_imm(rng, tracks):
    states = rng.normal(0.0, 1.0, (tracks, kalman.MODELS, 4))
    a = rng.normal(0.0, 0.3, (tracks, kalman.MODELS, 4, 4))
    covs = a @ np.swapaxes(a, 2, 3) + 0.01 * np.eye(4)
    probs = rng.dirichlet(np.ones(kalman.MODELS), tracks)
    return states, covs, probs


def test_the_compiled_imm_steps_match_the_numpy_filter():
    rng = np.random.default_rng(3)
    states, covs, probs = _random_imm(rng, 40)
    reference = [x.copy() for x in (states, covs, probs)]
    kalman.predict(*reference, 0.1, 0.5, 4.0)
    tracking_kernels.imm_predict(states, covs, probs, *kalman.model_matrices(0.1, 0.5, 4.0))
    for got, want in zip((states, covs, probs), reference):
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    measured = rng.normal(0.0, 1.0, (40, 2))
    noise = np.tile(np.diag([0.03 ** 2, 0.05 ** 2]), (40, 1, 1))
    kalman.update(*reference, measured, noise)
    tracking_kernels.imm_update(states, covs, probs, measured, noise)
    for got, want in zip((states, covs, probs), reference):
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    for got, want in zip(tracking_kernels.imm_combine(states, covs, probs), kalman.combine(*reference)):
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("known", [True, False], ids=["radius-known", "radius-fitted"])
def test_the_compiled_circle_fit_matches_the_numpy_fit(known):
    """Arcs of 40-120 degrees of circles of 0.1-0.4 m with 0.01 m noise, a missing return in each."""
    rng = np.random.default_rng(5)
    points, first, last, centres, radii = [], [], [], [], []
    for k in range(12):
        centre, radius = rng.uniform(-3.0, 3.0, 2), rng.uniform(0.1, 0.4)
        start, span = rng.uniform(-np.pi, np.pi), np.radians(rng.uniform(40.0, 120.0))
        angles = np.linspace(start, start + span, int(rng.integers(5, 15)))
        arc = centre + (radius + rng.normal(0.0, 0.01, len(angles)))[:, None] * \
            np.column_stack([np.cos(angles), np.sin(angles)])
        arc[len(arc) // 2] = np.nan
        first.append(sum(len(p) for p in points))
        last.append(first[-1] + len(arc) - 1)
        points.append(arc)
        centres.append(centre + rng.normal(0.0, 0.05, 2))
        radii.append(radius if known else 0.25)
    args = (np.concatenate(points), np.array(first), np.array(last), np.array(radii), np.full(12, known),
            np.array(centres), 0.01)
    want = fit_circles(*args)
    got = tracking_kernels.fit_circles(*args, FIT_ITERATIONS, FIT_DAMPING, FIXED_INFORMATION)
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_the_compiled_segmentation_matches_the_array_form(seed):
    """Crowds in a room seen from both lidars, with structure flags and some beams lost."""
    rng = np.random.default_rng(seed)
    people = [Cylinder(rng.uniform(0.1, 0.4), tuple(rng.uniform(-4.0, 4.0, 2))) for _ in range(20)]
    room = [(-5, -4, 5, -4), (5, -4, 5, 4), (5, 4, -5, 4), (-5, 4, -5, -4), (1.0, 0.5, 3.0, 0.7)]
    compared = 0
    for scan in scans_at((0.0, 0.0, rng.uniform(-3.0, 3.0)), 0.0, people, room, rng=rng):
        scan.ranges[rng.random(len(scan.ranges)) < 0.05] = np.nan
        flags = rng.random(len(scan.ranges)) < 0.3
        want = segment_reference(scan, 0.17, 0.05, 0.01, 3, flags, 7)
        got = segment(scan, 0.17, 0.05, 0.01, 3, flags, 7)
        compared += len(want)
        for name in Clusters._FIELDS:
            np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-9, atol=1e-12, err_msg=name)
    assert compared >= 8
