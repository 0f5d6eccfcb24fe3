"""Correlative scan matching (Olson, "Real-time correlative scan matching", 2009), as Cartographer and slam_toolbox
use it: the pose of a scan in a map is the one that puts the most returns where the map expects returns.

The map becomes a likelihood field (CorrelationGrid). match() scores every pose of a window around a prior at the
grid's resolution, made fast by branch and bound over max-pooled copies of the field (Hess et al., 2016), then
refines the best below the cell size on the bicubic interpolated field. The covariance is Olson's: the spread of
the poses of the window that score nearly as well as the best. global_candidates() searches the whole grid at
every heading, on a grid coarsened twice, and refines its finds with match().
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.slam import matcher_kernels as kernels

#: cells a CorrelationGrid may hold (a 100 m square at 0.05 m; the search copies the part it reaches a few times)
MAX_CELLS = 4_000_000
#: cell sizes (m): below the least, cell indices of a 100 km map would overflow 32 bits; above the most, a cell is
#: wider than a robot and a match tells little
MIN_RESOLUTION, MAX_RESOLUTION = 0.005, 1.0
#: the farthest a map point, prior or return may lie from the frame's origin (m)
MAX_COORDINATE = 100_000.0
#: points from_points takes (a few hundred scans of two lidars)
MAX_MAP_POINTS = 2_000_000
#: returns match() takes (several merged scans; ScanPoints holds up to 16 384)
MAX_RETURNS = 65_536
#: widest smear (m): the field's construction touches (6 deviations / resolution)^2 cells per point
MAX_SMEAR = 1.0
#: translations per axis of a match's window (a 25 m half-width at 0.05 m)
MAX_WINDOW_CELLS = 1025
#: headings one search may try
MAX_ANGLES = 8192
#: candidates global_candidates returns at most
MAX_CANDIDATES = 100
#: global candidates differ by at least this translation (m) or this heading (rad)
CANDIDATE_SEPARATION = 0.5
CANDIDATE_ANGLE_SEPARATION = 0.5
#: global_candidates searches a grid this many times coarser, then refines each find on the full grid
GLOBAL_COARSENING = 2
#: coarse finds global_candidates refines beyond ``count``, as refinement (merging two) and the mask drop some
GLOBAL_SPARES = 8
#: the global search's first nodes span 2**GLOBAL_ROOT_DEPTH coarse cells (3.2 m at 0.05 m)
GLOBAL_ROOT_DEPTH = 5
#: poses of the window the covariance samples (the lattice is thinned evenly to stay under this)
COVARIANCE_POSES = 4096
#: a pose counts towards the covariance if it scores at least this fraction of the best (Olson's "good" poses)
GOOD_FRACTION = 0.9
#: Levenberg-Marquardt iterations of the sub-cell refinement
REFINE_ITERATIONS = 30
#: the refinement pulls every return's interpolated field towards this, above the field's peak of 1 so that a
#: bicubic overshoot past 1 near a wall is not a second optimum (Cartographer's grids peak at 0.9 for the same end)
REFINE_TARGET = 1.1
#: Karto's gain in its distance and angle penalties (ScanMatcher's DISTANCE_PENALTY_GAIN, ANGLE_PENALTY_GAIN)
PENALTY_GAIN = 0.2


@dataclass(frozen=True, eq=False)
class CorrelationGrid:
    """The map as the matcher sees it: per cell, how likely a laser return lands there: 1 on an occupied cell,
    a Gaussian of the distance (smear_deviation) around it; the search builds coarser max-pooled levels from it.
    Built from points, the distance is the exact one from the cell's centre, so the field peaks on the walls
    themselves (a cell holding a return is >= 0.94 at 0.05 m and 0.1 m, 1 where a return sits at its centre):
    the sub-cell refinement needs that, a cell set to 1 whichever part of it the wall crosses biases it.

    ``origin`` is the (x, y) of cell (0, 0)'s lower-left corner; ``data`` float32 (rows, cols), rows along y."""
    resolution: float
    origin: tuple[float, float]
    data: np.ndarray

    def __post_init__(self):
        _check_number("resolution", self.resolution, MIN_RESOLUTION, MAX_RESOLUTION)
        if len(self.origin) != 2 or not all(math.isfinite(v) and abs(v) <= MAX_COORDINATE for v in self.origin):
            raise ValueError(f"origin: expected finite (x, y) within {MAX_COORDINATE} m, got {self.origin!r}")
        data = self.data
        if not isinstance(data, np.ndarray) or data.dtype != np.float32 or data.ndim != 2 or 0 in data.shape:
            raise ValueError(f"data: expected a non-empty 2-D float32 array, got "
                             f"{getattr(data, 'dtype', type(data).__name__)} {np.shape(data)}")
        if data.size > MAX_CELLS:
            raise ValueError(f"data: at most {MAX_CELLS} cells, got {data.shape}")
        if not (np.isfinite(data).all() and data.min() >= 0.0 and data.max() <= 1.0):
            raise ValueError("data: every cell must be a likelihood in 0..1")
        frozen = np.ascontiguousarray(data).view()
        frozen.setflags(write=False)
        object.__setattr__(self, "data", frozen)

    @classmethod
    def from_points(cls, points, resolution=0.05, smear_deviation=0.1, margin=1.0) -> CorrelationGrid:
        """The field of map-frame returns (N, 2), e.g. the last few scans': the grid covers their bounds plus
        ``margin`` (at least the smear's reach and two cells, so that the returns at the border keep the outer
        side of their peak); each cell is the Gaussian of its centre's distance to the nearest return."""
        points = _checked_points(points, "points", MAX_MAP_POINTS)
        _check_number("smear_deviation", smear_deviation, 0.0, MAX_SMEAR, low_open=True)
        _check_number("resolution", resolution, MIN_RESOLUTION, MAX_RESOLUTION)
        _check_number("margin", margin, 0.0, MAX_COORDINATE)
        margin = max(margin, kernels.SMEAR_REACH * smear_deviation + 2 * resolution)
        low = points.min(axis=0) - margin
        cols, rows = (np.floor((points.max(axis=0) + margin - low) / resolution).astype(np.int64) + 1)
        if rows * cols > MAX_CELLS:
            raise ValueError(f"points: their bounds plus margin need {rows} x {cols} cells at {resolution} m, "
                             f"more than MAX_CELLS = {MAX_CELLS}")
        data = np.zeros((rows, cols), np.float32)
        # one point per half cell (their centroid, within 0.36 cells of each): overlapping scans repeat their walls
        kernels.splat_likelihood(data, low[0], low[1], resolution, _voxel_filter(points, resolution / 2),
                                 smear_deviation)
        return cls(float(resolution), (float(low[0]), float(low[1])), data)

    @classmethod
    def from_occupancy(cls, data, resolution, origin, smear_deviation=0.1, occupied_threshold=65
                       ) -> CorrelationGrid:
        """The field of an occupancy grid (int8 (rows, cols) in nav_msgs/OccupancyGrid order, -1 unknown, 0..100);
        ``origin`` (x, y, yaw) with yaw 0. Cells >= occupied_threshold are 1 (the Gaussian of the distance between
        cell centres, all a grid knows); unknown ones count as free."""
        data = np.asarray(data)
        if data.ndim != 2 or 0 in data.shape or not np.issubdtype(data.dtype, np.integer):
            raise ValueError(f"data: expected a non-empty 2-D int8 array, got {data.dtype} {data.shape}")
        if data.size > MAX_CELLS:
            raise ValueError(f"data: at most {MAX_CELLS} cells, got {data.shape}")
        if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
            raise ValueError(f"origin: expected finite (x, y, yaw), got {origin!r}")
        if origin[2] != 0.0:
            raise ValueError(f"origin: yaw must be 0 (a rotated map is not supported), got {origin[2]!r}")
        if not (isinstance(occupied_threshold, (int, np.integer)) and 1 <= occupied_threshold <= 100):
            raise ValueError(f"occupied_threshold: expected an integer in 1..100, got {occupied_threshold!r}")
        _check_number("smear_deviation", smear_deviation, 0.0, MAX_SMEAR, low_open=True)
        _check_number("resolution", resolution, MIN_RESOLUTION, MAX_RESOLUTION)
        occupied = data >= occupied_threshold
        centres = (np.argwhere(occupied)[:, ::-1] + 0.5) * resolution + np.array(origin[:2], dtype=np.float64)
        field = np.zeros(data.shape, np.float32)
        kernels.splat_likelihood(field, float(origin[0]), float(origin[1]), float(resolution), centres,
                                 smear_deviation)
        return cls(float(resolution), (float(origin[0]), float(origin[1])), field)


@dataclass(frozen=True)
class Match:
    """A scan's pose in a grid's frame, how well it fits and how sure the fit is."""
    pose: tuple[float, float, float]   # the robot base's pose in the grid's frame
    response: float                    # 0..1: the mean grid value at the scan's returns (1 = every return on a wall)
    covariance: np.ndarray             # 3x3, from the spread of good responses over the search window (Olson)


class ScanMatcher:
    """Matches scans (returns in the robot's base frame) against CorrelationGrids."""

    def __init__(self, search_half_width=0.5, search_half_angle=0.35, angle_resolution=0.0, refine=True,
                 distance_variance_penalty=math.inf, angle_variance_penalty=math.inf,
                 minimum_distance_penalty=0.5, minimum_angle_penalty=0.9):
        """The window around a prior: +-search_half_width (m) in x and y, +-search_half_angle (rad) in yaw;
        angle_resolution 0 derives the heading step from the farthest return, so that it moves about one cell.

        Karto's (slam_toolbox's) prior penalties: a candidate d metres and t radians from the prior has its response
        multiplied by max(1 - 0.2 d² / distance_variance_penalty, minimum_distance_penalty) and
        max(1 - 0.2 t² / angle_variance_penalty, minimum_angle_penalty), so that where the scan cannot tell (along a
        corridor) the prior wins. The variances default to inf: no penalty."""
        _check_number("search_half_width", search_half_width, 0.0, MAX_COORDINATE)
        _check_number("search_half_angle", search_half_angle, 0.0, math.pi)
        _check_number("angle_resolution", angle_resolution, 0.0, math.pi)
        for name, value in (("distance_variance_penalty", distance_variance_penalty),
                            ("angle_variance_penalty", angle_variance_penalty)):
            if not (isinstance(value, (int, float)) and value > 0.0 and not math.isnan(value)):
                raise ValueError(f"{name}: expected a positive number (inf: no penalty), got {value!r}")
        _check_number("minimum_distance_penalty", minimum_distance_penalty, 0.0, 1.0)
        _check_number("minimum_angle_penalty", minimum_angle_penalty, 0.0, 1.0)
        self.search_half_width = float(search_half_width)
        self.search_half_angle = float(search_half_angle)
        self.angle_resolution = float(angle_resolution)
        self.refine = bool(refine)
        self.penalties = (float(distance_variance_penalty), float(angle_variance_penalty),
                          float(minimum_distance_penalty), float(minimum_angle_penalty))

    def match(self, grid: CorrelationGrid, points, prior) -> Match:
        """The best pose of the window around ``prior`` (x, y, yaw) for ``points`` (N, 2) float64 returns in the
        base frame (ScanPoints.returns): exhaustive at the grid's resolution by branch and bound, then refined below
        the cell size, never leaving the window. The returns are thinned to one per cell first (a voxel filter),
        for speed and so that a dense patch of wall does not outvote the rest; the response is over those."""
        _check_grid(grid)
        points = _checked_points(points, "points", MAX_RETURNS)
        prior = _checked_pose(prior, "prior")
        res = grid.resolution
        returns = _voxel_filter(points, res)
        step = self._angle_step(returns, res)
        turns = int(math.floor(self.search_half_angle / step + 1e-9))
        half = int(math.floor(self.search_half_width / res + 1e-9))
        if 2 * turns + 1 > MAX_ANGLES:
            raise ValueError(f"angle_resolution: {step:.4g} rad over +-{self.search_half_angle} rad is more than "
                             f"MAX_ANGLES = {MAX_ANGLES} headings")
        if 2 * half + 1 > MAX_WINDOW_CELLS:
            raise ValueError(f"search_half_width: {self.search_half_width} m is more than MAX_WINDOW_CELLS = "
                             f"{MAX_WINDOW_CELLS} cells across at {res} m")
        angles = prior[2] + step * np.arange(-turns, turns + 1)
        cells = _cells(returns, angles, (prior[0] - grid.origin[0], prior[1] - grid.origin[1]), res)
        depth = int(math.ceil(math.log2(2 * half + 1)))
        levels, cells = _search_levels(grid.data, cells, half, depth)
        window = np.array([-half, half, -half, half], np.int64)
        distance_variance, angle_variance, min_distance, min_angle = self.penalties
        angle_penalty = np.maximum(1.0 - PENALTY_GAIN * (angles - prior[2]) ** 2 / angle_variance, min_angle)
        found, _, _ = kernels.best_first(levels, _EVERYWHERE, cells, window, depth, 1, angles, 0.0, 0.0,
                                         angle_penalty, PENALTY_GAIN * res * res / distance_variance, min_distance)
        a, row, col = (int(v) for v in found[0])
        pose = np.array([prior[0] + col * res, prior[1] + row * res, angles[a]])
        if self.refine:
            # below the lattice: within one step of the best node, and inside the window
            span = np.array([self.search_half_width, self.search_half_width, self.search_half_angle])
            step_box = np.array([res, res, step])
            refined = kernels.refine_pose(grid.data, *grid.origin, res, returns, pose,
                                          np.maximum(prior - span, pose - step_box),
                                          np.minimum(prior + span, pose + step_box), REFINE_TARGET, REFINE_ITERATIONS)
            if _response(grid, returns, refined) >= _response(grid, returns, pose):
                pose = refined
        covariance = _olson_covariance(levels, cells, angles, (a, row, col), half, res, step)
        yaw = math.atan2(math.sin(pose[2]), math.cos(pose[2]))
        return Match((float(pose[0]), float(pose[1]), yaw), _response(grid, returns, pose), covariance)

    def global_candidates(self, grid: CorrelationGrid, points, count, allowed=None) -> list[Match]:
        """The ``count`` best distinct poses over the whole grid and every heading (relocalizing a kidnapped robot),
        best first, each CANDIDATE_SEPARATION or CANDIDATE_ANGLE_SEPARATION from the others. ``allowed``: bool
        (rows, cols) mask of the cells the robot may stand on (None: all); fewer come back if too few fit."""
        _check_grid(grid)
        points = _checked_points(points, "points", MAX_RETURNS)
        if not (isinstance(count, (int, np.integer)) and 1 <= count <= MAX_CANDIDATES):
            raise ValueError(f"count: expected an integer in 1..{MAX_CANDIDATES}, got {count!r}")
        if allowed is not None:
            allowed = np.asarray(allowed)
            if allowed.dtype != np.bool_ or allowed.shape != grid.data.shape:
                raise ValueError(f"allowed: expected a bool array of the grid's shape {grid.data.shape}, got "
                                 f"{allowed.dtype} {allowed.shape}")
        coarse_res = grid.resolution * GLOBAL_COARSENING
        coarse = _coarsened(grid.data, GLOBAL_COARSENING)
        returns = _voxel_filter(points, coarse_res)
        step = _derived_angle_step(returns, coarse_res)
        headings = int(math.ceil(2.0 * math.pi / step))
        if headings > MAX_ANGLES:
            raise ValueError(f"points: returns up to {np.hypot(*returns.T).max():.1f} m away need {headings} "
                             f"headings at {coarse_res} m, more than MAX_ANGLES = {MAX_ANGLES}")
        angles = np.arange(headings) * (2.0 * math.pi / headings)
        cells = _cells(returns, angles, (0.5 * coarse_res, 0.5 * coarse_res), coarse_res)
        depth = min(GLOBAL_ROOT_DEPTH, int(math.ceil(math.log2(max(coarse.shape)))))
        mask = _EVERYWHERE if allowed is None else _pyramid(_coarsened(allowed, GLOBAL_COARSENING), depth)
        window = np.array([0, coarse.shape[0] - 1, 0, coarse.shape[1] - 1], np.int64)
        found, _, n = kernels.best_first(_pyramid(coarse, depth), mask, cells, window, depth, count + GLOBAL_SPARES,
                                         angles, CANDIDATE_SEPARATION / coarse_res, CANDIDATE_ANGLE_SEPARATION,
                                         np.ones(len(angles)), 0.0, 1.0)
        local = ScanMatcher(coarse_res, step, self.angle_resolution, self.refine, *self.penalties)
        matches = []
        for a, row, col in found[:n]:
            guess = (grid.origin[0] + (col + 0.5) * coarse_res, grid.origin[1] + (row + 0.5) * coarse_res, angles[a])
            match = local.match(grid, points, guess)
            if allowed is None or _allowed_at(allowed, grid, match.pose):
                matches.append(match)
        return _distinct(sorted(matches, key=lambda m: -m.response), count)

    def _angle_step(self, returns: np.ndarray, resolution: float) -> float:
        return self.angle_resolution if self.angle_resolution > 0.0 else _derived_angle_step(returns, resolution)


#: best_first's "allowed" for a search without a mask
_EVERYWHERE = np.zeros((0, 0, 0), np.uint8)


def _check_number(name: str, value, low: float, high: float, low_open: bool = False) -> None:
    """A finite real in [low, high] ((low, high] if low_open)."""
    real = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
    if not (real and math.isfinite(value) and low <= value <= high) or (low_open and value == low):
        raise ValueError(f"{name}: expected a finite value in {'(' if low_open else '['}{low}, {high}], got {value!r}")


def _check_grid(grid) -> None:
    if not isinstance(grid, CorrelationGrid):
        raise ValueError(f"grid: expected a CorrelationGrid, got {type(grid).__name__}")


def _checked_points(points, name: str, bound: int) -> np.ndarray:
    """(N, 2) float64 finite points within MAX_COORDINATE, 1 <= N <= bound."""
    array = np.asarray(points)
    if array.ndim != 2 or array.shape[1] != 2 or not np.issubdtype(array.dtype, np.number):
        raise ValueError(f"{name}: expected a numeric (N, 2) array, got {array.dtype} {array.shape}")
    if not 1 <= len(array) <= bound:
        raise ValueError(f"{name}: expected 1 to {bound} points, got {len(array)}")
    array = array.astype(np.float64)
    if not np.isfinite(array).all():
        raise ValueError(f"{name}: every coordinate must be finite (NaN or inf found)")
    if np.abs(array).max() > MAX_COORDINATE:
        raise ValueError(f"{name}: coordinates beyond MAX_COORDINATE = {MAX_COORDINATE} m")
    return array


def _checked_pose(pose, name: str) -> np.ndarray:
    try:
        array = np.asarray(pose, dtype=np.float64)
    except (TypeError, ValueError):
        array = None
    if array is None or array.shape != (3,) or not np.isfinite(array).all() or np.abs(array).max() > MAX_COORDINATE:
        raise ValueError(f"{name}: expected finite (x, y, yaw) within {MAX_COORDINATE}, got {pose!r}")
    return array


def _voxel_filter(points: np.ndarray, size: float) -> np.ndarray:
    """One point per size x size cell (the centroid of its points), so dense patches of wall do not outvote the
    rest and the search costs what the scan's extent costs, not its beam count."""
    cells = np.floor(points / size).astype(np.int64)
    cells -= cells.min(axis=0, initial=0)
    _, inverse, counts = np.unique(cells[:, 0] * (int(cells[:, 1].max(initial=0)) + 1) + cells[:, 1],
                                   return_inverse=True, return_counts=True)
    sums = [np.bincount(inverse.reshape(-1), points[:, k], len(counts)) for k in (0, 1)]
    return np.column_stack(sums) / counts[:, None]


def _derived_angle_step(returns: np.ndarray, resolution: float) -> float:
    """The heading step that moves the farthest return by one cell (Hess et al. 2016, eq. 7)."""
    reach = max(float(np.hypot(returns[:, 0], returns[:, 1]).max()), resolution)
    return math.acos(1.0 - resolution * resolution / (2.0 * reach * reach))


def _cells(returns: np.ndarray, angles: np.ndarray, offset, resolution: float) -> np.ndarray:
    """(A, N, 2) int32 (row, col) of each return rotated by each angle and moved by ``offset`` from the grid's
    origin: the cells a candidate moves by whole cells."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    x = c * returns[:, 0] - s * returns[:, 1] + offset[0]
    y = s * returns[:, 0] + c * returns[:, 1] + offset[1]
    return np.stack([np.floor(y / resolution), np.floor(x / resolution)], axis=-1).astype(np.int32)


def _pyramid(base: np.ndarray, depth: int) -> np.ndarray:
    """(depth + 1, rows, cols): level h holds the maximum of ``base`` over the 2**h x 2**h cells from each cell
    up and right (zero beyond the grid), the bound of a branch-and-bound node of that size."""
    levels = np.zeros((depth + 1, *base.shape), dtype=np.uint8 if base.dtype == np.bool_ else base.dtype)
    levels[0] = base
    for h in range(1, depth + 1):
        shift = 1 << (h - 1)
        level = levels[h - 1].copy()
        level[:-shift] = np.maximum(level[:-shift], level[shift:])
        level[:, :-shift] = np.maximum(level[:, :-shift], level[:, shift:])
        levels[h] = level
    return levels


def _search_levels(data: np.ndarray, cells: np.ndarray, half: int, depth: int) -> tuple[np.ndarray, np.ndarray]:
    """The pyramid of the part of ``data`` a window of +-half cells can reach, and ``cells`` in that part: a big
    map's pyramid would cost more than the match."""
    flat = cells.reshape(-1, 2)
    low = np.maximum(flat.min(axis=0) - half, 0)
    high = np.minimum(flat.max(axis=0) + half + (1 << depth), data.shape)
    if (high <= low).any():
        return np.zeros((depth + 1, 1, 1), np.float32), cells
    part = data[low[0]:high[0], low[1]:high[1]]
    return _pyramid(part, depth), (cells - low.astype(np.int32)).astype(np.int32)


def _coarsened(data: np.ndarray, factor: int) -> np.ndarray:
    """The maximum over factor x factor blocks (the last ones padded with zeros)."""
    rows, cols = data.shape
    padded = np.pad(data, ((0, -rows % factor), (0, -cols % factor)))
    return padded.reshape(padded.shape[0] // factor, factor, padded.shape[1] // factor, factor).max(axis=(1, 3))


def _response(grid: CorrelationGrid, returns: np.ndarray, pose: np.ndarray) -> float:
    return float(kernels.mean_response(grid.data, *grid.origin, grid.resolution, returns, pose))


def _olson_covariance(levels, cells, angles, best, half, resolution, step) -> np.ndarray:
    """Olson's covariance: the response-weighted second moment of the window's poses that score at least
    GOOD_FRACTION of the best, over a lattice through the best thinned to COVARIANCE_POSES, plus half a cell and
    half a heading step of quantisation."""
    width = 2 * half + 1
    stride = max(1, math.ceil((len(angles) * width * width / COVARIANCE_POSES) ** (1.0 / 3.0)))
    a = np.arange(best[0] % stride, len(angles), stride)
    rows = np.arange(-half + (best[1] + half) % stride, half + 1, stride)
    cols = np.arange(-half + (best[2] + half) % stride, half + 1, stride)
    candidates = np.stack(np.meshgrid(a, rows, cols, indexing="ij"), axis=-1).reshape(-1, 3).astype(np.int64)
    scores = kernels.candidate_scores(levels, cells, candidates)
    good = scores >= GOOD_FRACTION * scores.max()
    weights = scores[good] if scores.max() > 0.0 else np.ones(int(good.sum()))
    poses = np.column_stack((candidates[good, 2] * resolution, candidates[good, 1] * resolution,
                             angles[candidates[good, 0]]))
    mean = weights @ poses / weights.sum()
    spread = poses - mean
    covariance = (weights[:, None] * spread).T @ spread / weights.sum()
    covariance += np.diag([(resolution / 2) ** 2, (resolution / 2) ** 2, (step / 2) ** 2])
    return (covariance + covariance.T) / 2


def _allowed_at(allowed: np.ndarray, grid: CorrelationGrid, pose) -> bool:
    col = int(math.floor((pose[0] - grid.origin[0]) / grid.resolution))
    row = int(math.floor((pose[1] - grid.origin[1]) / grid.resolution))
    return 0 <= row < allowed.shape[0] and 0 <= col < allowed.shape[1] and bool(allowed[row, col])


def _distinct(matches: list[Match], count: int) -> list[Match]:
    """The best ``count`` of ``matches`` (best first) that keep the candidate separations from each other."""
    kept: list[Match] = []
    for match in matches:
        if all(math.dist(match.pose[:2], k.pose[:2]) >= CANDIDATE_SEPARATION
               or abs(math.remainder(match.pose[2] - k.pose[2], 2 * math.pi)) >= CANDIDATE_ANGLE_SEPARATION
               for k in kept):
            kept.append(match)
    return kept[:count]
