"""The pose graph closes a drifting loop, shrugs off a false loop closure, scales to a long session, survives a
save and refuses hostile input without changing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simplebot_navigation.geometry import compose2, pose_in_frame
from simplebot_navigation.slam.pose_graph import PoseGraph

#: odometry's declared 1-sigma per 1 m step: honest, i.e. it covers the seeded bias over a loop (the yaw bias of
#: 0.01 rad/step adds up to 0.4 rad after 40 steps, 1.6 sigma of the declared sqrt(40) * 0.04 rad)
ODOMETRY_COVARIANCE = np.diag([0.05**2, 0.05**2, 0.04**2])
#: what a scan matcher's loop closure typically claims: 5 cm, about 1 degree
LOOP_COVARIANCE = np.diag([0.05**2, 0.05**2, 0.02**2])


def square_loop(side=10.0, per_side=10) -> np.ndarray:
    """(4 * per_side, 3) true poses around a square, counter-clockwise, starting at the origin facing +x."""
    poses, pose, step = [], (0.0, 0.0, 0.0), side / per_side
    for k in range(4 * per_side):
        poses.append(pose)
        pose = compose2(pose, (step, 0.0, math.pi / 2 if k % per_side == per_side - 1 else 0.0))
    return np.array(poses)


def drifting_odometry(truth: np.ndarray, seed: int, yaw_bias=0.01, scale_bias=1.01):
    """Measured steps between consecutive true poses (a seeded bias in yaw and scale plus noise) and the
    dead-reckoned trajectory they give."""
    rng = np.random.default_rng(seed)
    steps, odometry = [], [tuple(truth[0])]
    for a, b in zip(truth[:-1], truth[1:]):
        dx, dy, dyaw = pose_in_frame(a, b)
        step = (dx * scale_bias + rng.normal(0, 0.02), dy + rng.normal(0, 0.02), dyaw + yaw_bias + rng.normal(0, 0.005))
        steps.append(step)
        odometry.append(compose2(odometry[-1], step))
    return steps, np.array(odometry)


def chain(odometry: np.ndarray, steps, covariance=ODOMETRY_COVARIANCE, **kwargs) -> PoseGraph:
    graph = PoseGraph(**kwargs)
    for pose in odometry:
        graph.add_node(pose)
    for k, step in enumerate(steps):
        graph.add_edge(k, k + 1, step, covariance, "odometry")
    return graph


def ate(poses: np.ndarray, truth: np.ndarray) -> float:
    """Absolute trajectory error, RMS of the position errors; no alignment, node 0 is anchored at the truth."""
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - truth[:, :2]) ** 2, axis=1))))


def closed_square(seed: int, false_closure: bool, **kwargs):
    truth = square_loop()
    steps, odometry = drifting_odometry(truth, seed)
    graph = chain(odometry, steps, **kwargs)
    graph.add_edge(len(truth) - 1, 0, pose_in_frame(truth[-1], truth[0]), LOOP_COVARIANCE, "loop")
    if false_closure:       # nodes 15 at (10, 5) and 35 at (0, 5), 10 m apart, claimed to coincide
        graph.add_edge(15, 35, (0.0, 0.0, 0.0), LOOP_COVARIANCE, "loop")
    graph.optimize()
    return truth, odometry, graph


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_loop_closure_removes_the_drift(seed):
    truth, odometry, graph = closed_square(seed, false_closure=False)
    assert np.linalg.norm(odometry[-1, :2] - truth[-1, :2]) > 1.5        # the drift is metres
    odometry_ate, closed_ate = ate(odometry, truth), ate(graph.poses, truth)
    # One closure cannot see the 1 % scale bias (a scaled square still closes): ~1 % of 5-14 m leaves ~0.1 m;
    # the bounds keep a 2x margin over that.
    assert closed_ate < 0.2 * odometry_ate
    assert closed_ate < 0.3
    np.testing.assert_allclose(graph.poses[0], truth[0], atol=1e-3)     # node 0 stays anchored


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_closure_beyond_what_odometry_admits_still_closes(seed):
    """Odometry claiming 0.03 rad a step puts the 0.4 rad drift at 2.1 sigma: from odometry's estimate Cauchy alone
    would write the closure off as an outlier; the Huber pass first brings it within reach."""
    truth = square_loop()
    steps, odometry = drifting_odometry(truth, seed)
    graph = chain(odometry, steps, covariance=np.diag([0.05**2, 0.05**2, 0.03**2]))
    graph.add_edge(len(truth) - 1, 0, pose_in_frame(truth[-1], truth[0]), LOOP_COVARIANCE, "loop")
    graph.optimize()
    assert ate(graph.poses, truth) < 0.2 * ate(odometry, truth)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_robust_kernel_ignores_a_false_loop_closure(seed):
    truth, _, correct = closed_square(seed, false_closure=False)
    _, _, robust = closed_square(seed, false_closure=True)
    _, _, plain = closed_square(seed, false_closure=True, robust_kernel="none")
    correct_ate = ate(correct.poses, truth)
    assert ate(robust.poses, truth) < 1.5 * correct_ate
    # Least squares folds the square to pull two sides 10 m apart together: metres of error, not centimetres.
    assert ate(plain.poses, truth) > 5 * correct_ate
    assert ate(plain.poses, truth) > 1.0


def test_a_thousand_nodes_with_closures_optimise():
    """Ten laps of a 100-node circle, each node closed against the node a lap before every 10 nodes."""
    laps, per_lap, radius = 10, 100, 8.0
    angle = 2 * math.pi / per_lap
    step = (2 * radius * math.sin(angle / 2), 0.0, angle)
    truth = [(0.0, 0.0, angle / 2)]
    for _ in range(laps * per_lap - 1):
        truth.append(compose2(truth[-1], step))
    truth = np.array(truth)
    steps, odometry = drifting_odometry(truth, seed=7, yaw_bias=0.002)
    graph = chain(odometry, steps)
    for j in range(per_lap, len(truth), 10):
        graph.add_edge(j - per_lap, j, pose_in_frame(truth[j - per_lap], truth[j]), LOOP_COVARIANCE, "loop")
    graph.optimize()
    assert len(graph) == 1000 and graph.poses.shape == (1000, 3)
    assert np.isfinite(graph.poses).all()
    assert ((-math.pi < graph.poses[:, 2]) & (graph.poses[:, 2] <= math.pi)).all()
    assert ate(graph.poses, truth) < 0.1 * ate(odometry, truth)     # ~8 m of drift down to ~0.1 m


def test_arrays_round_trip(tmp_path):
    _, _, graph = closed_square(0, false_closure=True)
    np.savez(tmp_path / "graph.npz", **graph.to_arrays())
    with np.load(tmp_path / "graph.npz", allow_pickle=False) as saved:
        rebuilt = PoseGraph.from_arrays(dict(saved))
    np.testing.assert_array_equal(rebuilt.poses, graph.poses)
    assert len(rebuilt.edges) == len(graph.edges) == 41
    for a, b in zip(rebuilt.edges, graph.edges):
        assert (a.i, a.j, a.relative, a.kind) == (b.i, b.j, b.relative, b.kind)
        np.testing.assert_array_equal(a.covariance, b.covariance)
    rebuilt.optimize()          # already at the optimum: stays there (to well within a millimetre)
    np.testing.assert_allclose(rebuilt.poses, graph.poses, atol=1e-4)


def corrupt(arrays: dict, key: str, change) -> dict:
    arrays = {k: v.copy() for k, v in arrays.items()}
    arrays[key] = change(arrays[key])
    return arrays


def set_item(index, value):
    def change(array):
        array[index] = value
        return array
    return change


@pytest.mark.parametrize("key, change", [
    ("poses", lambda a: a[:, :2]),
    ("poses", set_item((3, 1), np.nan)),
    ("edge_nodes", set_item((2, 1), 40)),
    ("edge_nodes", set_item((2, 1), -1)),
    ("edge_nodes", set_item((2, 1), 2)),
    ("edge_nodes", lambda a: a.astype(float)),
    ("edge_relative", set_item((0, 2), np.inf)),
    ("edge_relative", lambda a: a[:-1]),
    ("edge_covariance", set_item((4, 0, 0), -1.0)),
    ("edge_covariance", set_item((4, 0, 1), 1e-3)),
    ("edge_covariance", set_item((4, 2, 2), np.nan)),
    ("edge_covariance", lambda a: a[:, :2, :2]),
    ("edge_kinds", set_item(5, "guess")),
])
def test_corrupt_arrays_are_refused_by_name(key, change):
    arrays = closed_square(0, false_closure=False)[2].to_arrays()
    with pytest.raises(ValueError, match=key):
        PoseGraph.from_arrays(corrupt(arrays, key, change))


def test_missing_arrays_are_named():
    arrays = closed_square(0, false_closure=False)[2].to_arrays()
    del arrays["edge_kinds"]
    with pytest.raises(ValueError, match="edge_kinds"):
        PoseGraph.from_arrays(arrays)


@pytest.mark.parametrize("args, name", [
    ((0, 1, (np.nan, 0.0, 0.0), ODOMETRY_COVARIANCE, "odometry"), "relative"),
    ((0, 1, (0.0, np.inf, 0.0), ODOMETRY_COVARIANCE, "odometry"), "relative"),
    ((0, 1, (0.0, 0.0), ODOMETRY_COVARIANCE, "odometry"), "relative"),
    ((0, 1, (1.0, 0.0, 0.0), -ODOMETRY_COVARIANCE, "odometry"), "covariance"),
    ((0, 1, (1.0, 0.0, 0.0), np.diag([1.0, 1.0, 0.0]), "odometry"), "covariance"),
    ((0, 1, (1.0, 0.0, 0.0), np.array([[1, 2, 0], [0, 1, 0], [0, 0, 1.0]]), "odometry"), "covariance"),
    ((0, 1, (1.0, 0.0, 0.0), np.eye(2), "odometry"), "covariance"),
    ((0, 1, (1.0, 0.0, 0.0), np.full((3, 3), np.nan), "odometry"), "covariance"),
    ((0, 3, (1.0, 0.0, 0.0), ODOMETRY_COVARIANCE, "odometry"), "j"),
    ((-1, 1, (1.0, 0.0, 0.0), ODOMETRY_COVARIANCE, "odometry"), "i"),
    ((True, 1, (1.0, 0.0, 0.0), ODOMETRY_COVARIANCE, "odometry"), "i"),
    ((1, 1, (1.0, 0.0, 0.0), ODOMETRY_COVARIANCE, "odometry"), "i, j"),
    ((0, 1, (1.0, 0.0, 0.0), ODOMETRY_COVARIANCE, "gps"), "kind"),
])
def test_hostile_edges_are_refused_and_change_nothing(args, name):
    graph = PoseGraph()
    for pose in [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.1)]:
        graph.add_node(pose)
    graph.add_edge(0, 1, (1.0, 0.0, 0.0), ODOMETRY_COVARIANCE, "odometry")
    before = graph.to_arrays()
    with pytest.raises(ValueError, match=f"^{name}"):
        graph.add_edge(*args)
    after = graph.to_arrays()
    assert len(graph) == 3 and len(graph.edges) == 1
    for key in before:
        np.testing.assert_array_equal(after[key], before[key])


@pytest.mark.parametrize("pose", [(np.nan, 0.0, 0.0), (0.0, 0.0, -np.inf), (0.0, 0.0), (1e9, 0.0, 0.0)])
def test_hostile_nodes_are_refused(pose):
    graph = PoseGraph()
    with pytest.raises(ValueError, match="^pose"):
        graph.add_node(pose)
    assert len(graph) == 0


@pytest.mark.parametrize("kwargs, name", [({"robust_kernel": "tukey"}, "robust_kernel"),
                                          ({"robust_scale": 0.0}, "robust_scale"),
                                          ({"robust_scale": math.nan}, "robust_scale")])
def test_bad_kernels_are_refused(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}"):
        PoseGraph(**kwargs)


def test_a_node_without_edges_is_not_optimised():
    graph = PoseGraph()
    for pose in [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (5.0, 5.0, 0.0)]:
        graph.add_node(pose)
    graph.add_edge(0, 1, (1.1, 0.0, 0.0), ODOMETRY_COVARIANCE, "odometry")
    with pytest.raises(ValueError, match="node 2"):
        graph.optimize()
    np.testing.assert_array_equal(graph.poses[1], (1.0, 0.0, 0.0))
