"""Global relocalization by slam's correlative scan matcher: where on the whole map the robot's latest scans fit
best, so that global localization and recovery put their particles round those poses (docs/reference.md §8.4).

Why: spread uniformly, even 20000 particles leave about one per 0.5 m x 0.5 m x 10 deg bin of the lab's free space,
so the true pose is often sampled too coarsely to beat a room that looks alike, and the filter locks onto that room.
ScanMatcher.global_candidates scores every pose and heading of the map; on the lab's six kidnap places it ranks the
true pose first each time (0.15-0.4 s on two shared cores).

- The map's likelihood field (CorrelationGrid, in the grid's own frame so that a rotated map works too) is built at
  the first match and kept: an Amcl is per map, and so is its Relocalizer.
- The latest scans of every source (laser) are kept with the odometry pose at their time; a match merges them into
  the base frame at the particles' odometry pose, so that two lidars out of step add up.
- Particles: ``global_localization_uniform_share`` of them uniform over the free cells (a candidate list that misses
  the robot can still be recovered from), the rest shared among the candidates in proportion to their response,
  each drawn from a Gaussian round it: the match's covariance plus SEED_DEVIATION. Candidates matched earlier are
  moved by the odometry since.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from simplebot_navigation.geometry import compose2, inverse2, transform_points
from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.localization.laser_models import RangeScan, range_limits
from simplebot_navigation.localization.map_grid import OCCUPIED, AmclMap
from simplebot_navigation.localization.motion_model import wrap
from simplebot_navigation.slam.scan_matcher import (MAX_CELLS, MAX_RESOLUTION, MAX_RETURNS, MIN_RESOLUTION,
                                                    CorrelationGrid, ScanMatcher)

#: how far a wall's likelihood spreads in the matcher's field (m): slam's correlation_search_space_smear_deviation
SMEAR_DEVIATION = 0.1
#: spread round a candidate (x, y in m, yaw in rad) added to the match's covariance, which only spans the coarse
#: search's cell: the filter's motion noise and the likelihood model then have room to settle the pose
SEED_DEVIATION = (0.1, 0.1, 0.05)
#: returns farther from the robot are left out: the whole-map search's headings grow with the farthest return
MAX_MATCH_RANGE = 30.0
#: fewer returns than this fit anywhere; the particles stay uniform then
MIN_MATCH_RETURNS = 20

Candidates = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]   # odometry, poses (K, 3), responses, covariances


class Relocalizer:
    """Candidate poses of the robot on one map from its latest scans, and particles drawn round them."""

    def __init__(self, amap: AmclMap, map_data):
        self.map = amap
        data = np.asarray(map_data)
        usable = data.size <= MAX_CELLS and MIN_RESOLUTION <= amap.resolution <= MAX_RESOLUTION
        self._data = data if usable else None       # a map the matcher cannot take: uniform particles only
        self._grid: CorrelationGrid | None = None
        self._matcher = ScanMatcher()
        self.forget()

    def forget(self) -> None:
        """No scans, no candidates, nothing pending (the filter starts over)."""
        self._scans: dict[str, tuple[tuple, list[RangeScan]]] = {}
        self._known: set[str] = set()
        self._candidates: Candidates | None = None
        self._matched_at: float | None = None
        self.pending = False

    def request(self) -> None:
        """Global localization: seed the particles from the scans that come next. Not from those already kept:
        they may predate the kidnap the call answers."""
        self._scans, self._candidates, self.pending = {}, None, True

    def observe(self, source: str, scans: list[RangeScan], odom) -> bool:
        """Keep ``source``'s latest scans with the odometry pose at their time; True when a requested seeding is
        due: every source seen so far has sent a scan since the request, or one sent a second (the others are
        silent)."""
        repeat = source in self._scans
        self._scans[source] = (tuple(odom), scans)
        self._known.add(source)
        return self.pending and (repeat or self._known <= self._scans.keys())

    def match(self, odom, stamp: float | None, params: AmclParams) -> bool:
        """The best global_localization_candidates poses of the kept scans, at the odometry pose ``odom``; False
        (and none kept) when the scans hold too few returns or the matcher cannot take the map."""
        self._matched_at, self._candidates = stamp, None
        points = self._returns(odom, params)
        if self._data is None or len(points) < MIN_MATCH_RETURNS or params.global_localization_candidates == 0:
            return False
        if self._grid is None:
            self._grid = CorrelationGrid.from_occupancy(self._data, self.map.resolution, (0.0, 0.0, 0.0),
                                                        SMEAR_DEVIATION, occupied_threshold=OCCUPIED)
        found = [m for m in self._matcher.global_candidates(self._grid, points, params.global_localization_candidates,
                                                            self.map.free) if m.response > 0.0]
        if found:
            self._candidates = (np.asarray(odom, dtype=float), np.array([m.pose for m in found]),
                                np.array([m.response for m in found]), np.array([m.covariance for m in found]))
        return bool(found)

    @property
    def candidates(self) -> tuple[np.ndarray, np.ndarray]:
        """The last match's poses (K, 3) in the global frame, as matched (not moved since), and their responses,
        best first; empty without a match."""
        if self._candidates is None:
            return np.zeros((0, 3)), np.zeros(0)
        poses = transform_points(self.map.origin, self._candidates[1])
        poses[:, 2] = wrap(poses[:, 2])
        return poses, self._candidates[2].copy()

    def poses(self, n: int, params: AmclParams, odom, rng: np.random.Generator,
              uniform: Callable[[int], np.ndarray]) -> np.ndarray:
        """n particles in the global frame, shuffled: the uniform share from ``uniform``, the rest round the last
        candidates moved by the odometry from their match to ``odom`` (all uniform without candidates)."""
        if self._candidates is None:
            return uniform(n)
        matched_odom, poses, responses, covariances = self._candidates
        n_uniform = int(round(params.global_localization_uniform_share * n))
        counts = rng.multinomial(n - n_uniform, responses / responses.sum())
        moved = _moved(poses, compose2(inverse2(matched_odom), odom))
        seed = np.diag(np.square(SEED_DEVIATION))
        drawn = [moved[k] + rng.standard_normal((c, 3)) @ np.linalg.cholesky(covariances[k] + seed).T
                 for k, c in enumerate(counts) if c]
        around = transform_points(self.map.origin, np.concatenate(drawn)) if drawn else np.zeros((0, 3))
        around[:, 2] = wrap(around[:, 2])
        out = np.concatenate((uniform(n_uniform), around))
        return out[rng.permutation(n)]

    def recovery_poses(self, n: int, params: AmclParams, odom, stamp: float | None, rng: np.random.Generator,
                       uniform: Callable[[int], np.ndarray]) -> np.ndarray:
        """Recovery's n injected poses: round the candidates, matched anew from the kept scans when the last match
        is recovery_match_interval old by ``stamp`` (or time went back); uniform without a stamp (nothing to
        bound the matcher's cost by), without candidates or scans, or with global_localization_candidates 0."""
        if stamp is None or params.global_localization_candidates == 0:
            return uniform(n)
        due = self._matched_at is None or not 0.0 <= stamp - self._matched_at < params.recovery_match_interval
        if due and self._scans:
            self.match(odom, stamp, params)
        return self.poses(n, params, odom, rng, uniform)

    def _returns(self, odom, params: AmclParams) -> np.ndarray:
        """The kept scans' returns (N, 2) in the base frame at the odometry pose ``odom``, within MAX_MATCH_RANGE
        of it, thinned evenly to the matcher's MAX_RETURNS."""
        to_reference = inverse2(odom)
        parts = [transform_points(compose2(to_reference, scan_odom), _scan_returns(scan, params))
                 for scan_odom, scans in self._scans.values() for scan in scans]
        points = np.concatenate(parts) if parts else np.zeros((0, 2))
        points = points[np.isfinite(points).all(axis=1)]
        points = points[np.hypot(points[:, 0], points[:, 1]) <= MAX_MATCH_RANGE]
        return points[::math.ceil(len(points) / MAX_RETURNS)] if len(points) > MAX_RETURNS else points


def _scan_returns(scan: RangeScan, params: AmclParams) -> np.ndarray:
    """(M, 2) the ends of the beams that returned (above range_min, below range_max as amcl's models limit them;
    not NaN), in the base frame."""
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    range_min, range_max = range_limits(scan, params)
    with np.errstate(invalid="ignore"):
        beams = np.flatnonzero((ranges > range_min) & (ranges < range_max))
    sx, sy, syaw = scan.sensor_pose
    angles = syaw + scan.angle_min + beams * scan.angle_increment
    return np.column_stack((sx + ranges[beams] * np.cos(angles), sy + ranges[beams] * np.sin(angles)))


def _moved(poses: np.ndarray, delta) -> np.ndarray:
    """Each pose (K, 3) composed with the same relative motion ``delta`` (x, y, yaw in the robot's frame)."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    return np.column_stack((poses[:, 0] + c * delta[0] - s * delta[1], poses[:, 1] + s * delta[0] + c * delta[1],
                            poses[:, 2] + delta[2]))
