"""The pose graph: the robot's poses at its scans, tied together by odometry and scan matching, and optimised
by gtsam's Levenberg-Marquardt so that a loop closure spreads the drift it reveals over the whole trajectory.

An edge's covariance whitens its error (Mahalanobis distance); a matching edge ("scan" or "loop") then goes
through a robust kernel (Cauchy by default): once its whitened error is large, its pull on the poses fades, so
one false loop closure the matcher let through cannot fold the map. Odometry edges stay least squares: they are
never outliers, only noisy. The kernel works best when odometry's covariances are honest (cover its slip and
bias): a true closure must then sit within a few sigmas of where odometry puts it.

Cauchy's cost flattens out, so from odometry's drifted estimate a true closure a few sigmas off can look like an
outlier too, and Levenberg-Marquardt stops short of closing the loop. optimize() therefore first runs with
Huber's kernel (convex: each closure pulls, none pulls harder than a set force) and then with Cauchy's from where
that left the poses, within reach of the closures that agree with the rest and far from those that do not.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import gtsam
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from simplebot_navigation.geometry import normalize_theta

#: nodes a graph may hold: one per 0.5 m of travel is 50 km, hours of mapping for a batch optimisation
MAX_NODES = 100_000
#: edges a graph may hold: odometry plus a handful of matches per node
MAX_EDGES = 10 * MAX_NODES
#: bound on |x|, |y| (metres) and |yaw| (radians) of a pose or a relative pose: 1000 km, far beyond any map
MAX_COORDINATE = 1e6
#: an edge covariance's eigenvalues: standard deviations from 1 um (or urad) to 1 km (or krad)
MIN_VARIANCE, MAX_VARIANCE = 1e-12, 1e6
#: the prior that anchors node 0 where it was added (the map frame's origin stays put): sigma in m and rad
ANCHOR_SIGMA = 1e-4
#: Levenberg-Marquardt iterations one optimize() call may ask for
MAX_ITERATIONS = 10_000
KINDS = ("odometry", "scan", "loop")
#: kinds that come from the scan matcher, which can be wrong, and so go through the robust kernel
MATCHED_KINDS = ("scan", "loop")
ROBUST_KERNELS = ("cauchy", "huber", "none")
ARRAY_KEYS = ("poses", "edge_nodes", "edge_relative", "edge_covariance", "edge_kinds")


@dataclass(frozen=True, eq=False)
class Edge:
    """What odometry or the matcher says about nodes ``i`` and ``j``: ``relative`` is node j's pose in node i's
    frame (dx, dy, dyaw), ``covariance`` its 3x3 uncertainty in that order."""
    i: int
    j: int
    relative: tuple[float, float, float]
    covariance: np.ndarray
    kind: str


def _finite_rows(values, name: str, rows: int | None = None) -> np.ndarray:
    """``values`` as an (n, 3) float64 array of bounded finite numbers (n = ``rows`` when given)."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected numbers (x, y, yaw), got {values!r}") from None
    if array.ndim != 2 or array.shape[1] != 3 or (rows is not None and len(array) != rows):
        raise ValueError(f"{name}: expected shape ({'N' if rows is None else rows}, 3), got {array.shape}")
    bad = ~np.isfinite(array) | (np.abs(array) > MAX_COORDINATE)
    if bad.any():
        row = int(np.argwhere(bad)[0, 0])
        raise ValueError(f"{name}: row {row} {array[row].tolist()} is not finite or beyond {MAX_COORDINATE:g}")
    return array


def _covariances(values, name: str, rows: int) -> np.ndarray:
    """``values`` as (rows, 3, 3) symmetric positive definite covariances with eigenvalues in the bounds."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected 3x3 numbers, got {values!r}") from None
    if array.shape != (rows, 3, 3):
        raise ValueError(f"{name}: expected shape ({rows}, 3, 3), got {array.shape}")
    finite = np.isfinite(array).all(axis=(1, 2))
    asymmetric = np.abs(array - array.transpose(0, 2, 1)).max(axis=(1, 2), initial=0.0) \
        > 1e-9 * np.abs(array).max(axis=(1, 2), initial=0.0)
    for problem, bad in (("not finite", ~finite), ("not symmetric", finite & asymmetric)):
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{name}[{k}]: {problem}: {array[k].tolist()}")
    eigenvalues = np.linalg.eigvalsh(array) if rows else np.zeros((0, 3))
    bad = (eigenvalues[:, 0] < MIN_VARIANCE) | (eigenvalues[:, 2] > MAX_VARIANCE)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{name}[{k}]: eigenvalues {eigenvalues[k].tolist()} not in [{MIN_VARIANCE:g}, "
                         f"{MAX_VARIANCE:g}] (not positive definite, or absurd)")
    return 0.5 * (array + array.transpose(0, 2, 1))


def _node_pairs(values, name: str, nodes: int) -> np.ndarray:
    """``values`` as (n, 2) int64 node indices, each below ``nodes``, no edge from a node to itself."""
    array = np.asarray(values)
    if array.ndim != 2 or array.shape[1] != 2 or (array.size and array.dtype.kind not in "iu"):
        raise ValueError(f"{name}: expected an (E, 2) integer array, got {array.dtype} {array.shape}")
    array = array.astype(np.int64)
    bad = (array < 0).any(axis=1) | (array >= nodes).any(axis=1) | (array[:, 0] == array[:, 1])
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{name}[{k}]: {array[k].tolist()} is not two different nodes of 0..{nodes - 1}")
    return array


def _kinds(values, name: str, rows: int) -> list[str]:
    array = np.asarray(values)
    if array.shape != (rows,):
        raise ValueError(f"{name}: expected shape ({rows},), got {array.shape}")
    kinds = [str(k) for k in array.tolist()]
    for k, kind in enumerate(kinds):
        if kind not in KINDS:
            raise ValueError(f"{name}[{k}]: {kind!r} is not one of {', '.join(KINDS)}")
    return kinds


def _edge(i: int, j: int, relative: np.ndarray, covariance: np.ndarray, kind: str) -> Edge:
    """An Edge of checked values, its covariance a read-only copy of its own."""
    covariance = covariance.copy()
    covariance.flags.writeable = False
    return Edge(i, j, (float(relative[0]), float(relative[1]), float(relative[2])), covariance, kind)


class PoseGraph:
    """Poses of the robot at its scans (nodes) and what odometry and the scan matcher say about pairs of them
    (edges), optimised by gtsam's Levenberg-Marquardt; matching edges carry a robust kernel so that one false
    loop closure cannot bend the map."""

    def __init__(self, robust_kernel: str = "cauchy", robust_scale: float = 1.0):
        if robust_kernel not in ROBUST_KERNELS:
            raise ValueError(f"robust_kernel: expected one of {', '.join(ROBUST_KERNELS)}, got {robust_kernel!r}")
        if isinstance(robust_scale, bool) or not isinstance(robust_scale, numbers.Real) \
                or not (math.isfinite(robust_scale) and robust_scale > 0.0):
            raise ValueError(f"robust_scale: expected a positive number of sigmas, got {robust_scale!r}")
        self.robust_kernel = robust_kernel
        self.robust_scale = float(robust_scale)
        self._buffer = np.zeros((16, 3))     # the estimates, rows 0..len-1, room to add nodes without a copy each
        self._count = 0
        self._anchor = (0.0, 0.0, 0.0)      # node 0's pose as added: where the prior holds it
        self._edges: list[Edge] = []

    def __len__(self) -> int:
        return self._count

    @property
    def poses(self) -> np.ndarray:
        """(N, 3) the current estimates, yaw wrapped to (-pi, pi]."""
        poses = self._buffer[:self._count].copy()
        poses[:, 2] = -normalize_theta(-poses[:, 2])       # (-pi, pi], as atan2 gives
        return poses

    @property
    def edges(self) -> tuple[Edge, ...]:
        return tuple(self._edges)

    def add_node(self, pose) -> int:
        """A new node at ``pose`` (x, y, yaw), the optimiser's initial estimate; its index. Node 0 is anchored
        where it is added."""
        if self._count >= MAX_NODES:
            raise ValueError(f"add_node: the graph already holds MAX_NODES = {MAX_NODES} nodes")
        if np.shape(pose) != (3,):
            raise ValueError(f"pose: expected (x, y, yaw), got {pose!r}")
        row = _finite_rows([pose], "pose", rows=1)[0]
        if self._count == 0:
            self._anchor = tuple(row.tolist())
        if self._count == len(self._buffer):
            self._buffer = np.concatenate([self._buffer, np.zeros_like(self._buffer)])
        self._buffer[self._count] = row
        self._count += 1
        return self._count - 1

    def add_edge(self, i: int, j: int, relative, covariance, kind: str) -> None:
        """Node ``j`` seen from node ``i`` at ``relative`` (dx, dy, dyaw) with ``covariance`` (3x3, SPD)."""
        if len(self._edges) >= MAX_EDGES:
            raise ValueError(f"add_edge: the graph already holds MAX_EDGES = {MAX_EDGES} edges")
        for name, index in (("i", i), ("j", j)):
            if isinstance(index, bool) or not isinstance(index, numbers.Integral) \
                    or not 0 <= index < self._count:
                raise ValueError(f"{name}: {index!r} is not a node of 0..{self._count - 1}")
        if i == j:
            raise ValueError(f"i, j: an edge joins two different nodes, got {i} and {j}")
        if not isinstance(kind, str) or kind not in KINDS:
            raise ValueError(f"kind: {kind!r} is not one of {', '.join(KINDS)}")
        if np.shape(relative) != (3,):
            raise ValueError(f"relative: expected (dx, dy, dyaw), got {relative!r}")
        if np.shape(covariance) != (3, 3):
            raise ValueError(f"covariance: expected a 3x3 matrix, got shape {np.shape(covariance)}")
        self._edges.append(_edge(int(i), int(j), _finite_rows([relative], "relative", rows=1)[0],
                                 _covariances([covariance], "covariance", rows=1)[0], kind))

    def optimize(self, max_iterations: int = 100) -> None:
        """Move every node to where the edges agree best: Levenberg-Marquardt from the current estimates, with
        Huber's kernel and then Cauchy's when the kernel is Cauchy (module docstring)."""
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, numbers.Integral) \
                or not 1 <= max_iterations <= MAX_ITERATIONS:
            raise ValueError(f"max_iterations: expected 1..{MAX_ITERATIONS}, got {max_iterations!r}")
        if not self._count:
            return
        self._require_connected()
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(int(max_iterations))
        values = self._initial_values()
        for kernel in (("huber", "cauchy") if self.robust_kernel == "cauchy" else (self.robust_kernel,)):
            values = gtsam.LevenbergMarquardtOptimizer(self._factor_graph(kernel), values, params).optimize()
        for k in range(self._count):
            pose = values.atPose2(k)
            self._buffer[k] = pose.x(), pose.y(), pose.theta()

    def _require_connected(self) -> None:
        """Refuse to optimise a node no chain of edges ties to node 0: its pose would be undetermined."""
        n = self._count
        pairs = np.array([(e.i, e.j) for e in self._edges], dtype=np.int64).reshape(-1, 2)
        adjacency = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, labels = connected_components(adjacency, directed=False)
        loose = np.flatnonzero(labels != labels[0])
        if len(loose):
            raise ValueError(f"optimize: node {int(loose[0])} is tied to node 0 by no chain of edges")

    def _initial_values(self) -> gtsam.Values:
        values = gtsam.Values()
        for k, (x, y, yaw) in enumerate(self._buffer[:self._count].tolist()):
            values.insert(k, gtsam.Pose2(x, y, yaw))
        return values

    def _factor_graph(self, kernel: str) -> gtsam.NonlinearFactorGraph:
        graph = gtsam.NonlinearFactorGraph()
        anchor = gtsam.noiseModel.Isotropic.Sigma(3, ANCHOR_SIGMA)
        graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(*self._anchor), anchor))
        for edge in self._edges:
            noise = gtsam.noiseModel.Gaussian.Covariance(edge.covariance)
            if edge.kind in MATCHED_KINDS and kernel != "none":
                estimator = (gtsam.noiseModel.mEstimator.Cauchy if kernel == "cauchy"
                             else gtsam.noiseModel.mEstimator.Huber).Create(self.robust_scale)
                noise = gtsam.noiseModel.Robust.Create(estimator, noise)
            graph.add(gtsam.BetweenFactorPose2(edge.i, edge.j, gtsam.Pose2(*edge.relative), noise))
        return graph

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Everything from_arrays needs to rebuild the graph (np.savez-able without pickling)."""
        return {"poses": self._buffer[:self._count].copy(),
                "edge_nodes": np.array([(e.i, e.j) for e in self._edges], dtype=np.int64).reshape(-1, 2),
                "edge_relative": np.array([e.relative for e in self._edges], dtype=np.float64).reshape(-1, 3),
                "edge_covariance": np.array([e.covariance for e in self._edges], dtype=np.float64).reshape(-1, 3, 3),
                "edge_kinds": np.array([e.kind for e in self._edges], dtype=f"<U{max(map(len, KINDS))}")}

    @classmethod
    def from_arrays(cls, arrays, robust_kernel: str = "cauchy", robust_scale: float = 1.0) -> PoseGraph:
        """The graph to_arrays saved, every array checked first (ValueError naming the array and the row)."""
        missing = [key for key in ARRAY_KEYS if key not in arrays]
        if missing:
            raise ValueError(f"arrays: missing {', '.join(missing)} (expected {', '.join(ARRAY_KEYS)})")
        poses = _finite_rows(arrays["poses"], "poses")
        if not 1 <= len(poses) <= MAX_NODES:
            raise ValueError(f"poses: expected 1..{MAX_NODES} nodes, got {len(poses)}")
        nodes = _node_pairs(arrays["edge_nodes"], "edge_nodes", len(poses))
        if len(nodes) > MAX_EDGES:
            raise ValueError(f"edge_nodes: at most {MAX_EDGES} edges, got {len(nodes)}")
        relative = _finite_rows(arrays["edge_relative"], "edge_relative", rows=len(nodes))
        covariance = _covariances(arrays["edge_covariance"], "edge_covariance", rows=len(nodes))
        kinds = _kinds(arrays["edge_kinds"], "edge_kinds", rows=len(nodes))
        graph = cls(robust_kernel, robust_scale)
        graph._buffer, graph._count, graph._anchor = poses.copy(), len(poses), tuple(poses[0].tolist())
        graph._edges = [_edge(i, j, rel, cov, kind)
                        for (i, j), rel, cov, kind in zip(nodes.tolist(), relative, covariance, kinds)]
        return graph
