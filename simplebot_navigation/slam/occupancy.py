"""The SLAM map: an occupancy grid in log-odds that the scans paint as they come, and render(), which paints it
again from scratch once a loop closure has moved the poses.

Cells are fixed in the world: the grid's origin is always a whole number of cells (of whole 2 m chunks, in
fact) from (0, 0), and a point's cell is floor(x / resolution), whatever the grid's extent. So the grid can grow
without moving a cell, and rendering the same scans at the same poses gives the same cells.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from simplebot_navigation.maps.map_io import OccupancyMap, threshold_problem
from simplebot_navigation.slam.occupancy_kernels import integrate_beams
from simplebot_navigation.slam.scan_points import MAX_BEAMS, ScanPoints

#: cells a grid may hold: 16 M float32 cells are 64 MB, 200 m x 200 m at 5 cm
MAX_CELLS = 16_000_000
#: the grid grows in whole squares of this side (metres), so that growing (a copy of the grid) is rare
CHUNK_METRES = 2.0
#: cell sizes (metres) a grid accepts: 1 mm to 10 m
MIN_RESOLUTION, MAX_RESOLUTION = 0.001, 10.0
#: bound on |x| and |y| (metres) of a beam's points: 100 km, far beyond any map (keeps cell indices exact)
MAX_COORDINATE = 1e5
#: scans render() accepts: hours of mapping at a scan per half metre
MAX_SCANS = 100_000


def _logit(p: float) -> float:
    return math.log(p / (1.0 - p))


def _probability(value, name: str, low: float, high: float) -> float:
    """``value`` as a float strictly inside (low, high)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not low < value < high:
        raise ValueError(f"{name}: expected a probability in ({low}, {high}), got {value!r}")
    return float(value)


def _points(values, name: str) -> np.ndarray:
    """``values`` as (N, 2) float64 map-frame points, finite and within MAX_COORDINATE."""
    array = np.asarray(values)
    if array.ndim != 2 or array.shape[1] != 2 or array.dtype.kind not in "iuf":
        raise ValueError(f"{name}: expected an (N, 2) array of numbers, got {array.dtype} {array.shape}")
    array = array.astype(np.float64)
    bad = ~np.isfinite(array) | (np.abs(array) > MAX_COORDINATE)
    if bad.any():
        row = int(np.argwhere(bad)[0, 0])
        raise ValueError(f"{name}: row {row} {array[row].tolist()} is not finite or beyond {MAX_COORDINATE:g} m")
    return array


class LogOddsGrid:
    """An occupancy grid in log-odds that grows to hold whatever the robot sees: each beam clears the cells it
    crosses and, when it is a return, marks its end cell (ray casting, Bresenham in numba). Each integrate() call
    is one observation: a cell changes once per call at most, and a return's cell is not cleared by the scan
    that hit it."""

    def __init__(self, resolution: float = 0.05, hit_probability: float = 0.7, miss_probability: float = 0.4,
                 clamp: tuple[float, float] = (0.12, 0.97), max_cells: int = MAX_CELLS):
        if isinstance(resolution, bool) or not isinstance(resolution, numbers.Real) \
                or not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
            raise ValueError(f"resolution: expected {MIN_RESOLUTION}..{MAX_RESOLUTION} m, got {resolution!r}")
        hit = _probability(hit_probability, "hit_probability", 0.5, 1.0)
        miss = _probability(miss_probability, "miss_probability", 0.0, 0.5)
        if np.shape(clamp) != (2,):
            raise ValueError(f"clamp: expected (low, high) probabilities, got {clamp!r}")
        low = _probability(clamp[0], "clamp", 0.0, 0.5)
        high = _probability(clamp[1], "clamp", 0.5, 1.0)
        if isinstance(max_cells, bool) or not isinstance(max_cells, numbers.Integral) \
                or not 1 <= max_cells <= MAX_CELLS:
            raise ValueError(f"max_cells: expected 1..{MAX_CELLS}, got {max_cells!r}")
        self.resolution = float(resolution)
        self.max_cells = int(max_cells)
        self.hit_update, self.miss_update = _logit(hit), _logit(miss)
        self.low, self.high = _logit(low), _logit(high)
        self.chunk_cells = max(1, round(CHUNK_METRES / self.resolution))
        self._log_odds = np.zeros((0, 0), dtype=np.float32)
        self._first_cell = (0, 0)          # (col, row) of data[0, 0] counted from the cell at (0, 0)

    @property
    def origin(self) -> tuple[float, float]:
        """(x, y) of the lower-left corner of cell [0, 0], a whole number of cells from (0, 0)."""
        return self._first_cell[0] * self.resolution, self._first_cell[1] * self.resolution

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols); (0, 0) before the first beam."""
        return self._log_odds.shape

    @property
    def log_odds(self) -> np.ndarray:
        """(rows, cols) float32 log-odds of occupancy, 0 where never seen; a read-only view."""
        view = self._log_odds.view()
        view.flags.writeable = False
        return view

    def world_cells(self, points, name: str = "points") -> np.ndarray:
        """(N, 2) int64 (col, row) of map-frame points (N, 2) counted from the cell at (0, 0): a cell's name
        whatever the grid's extent."""
        return np.floor(_points(points, name) / self.resolution).astype(np.int64)

    def cells_of(self, points) -> np.ndarray:
        """(N, 2) int64 (col, row) of map-frame points (N, 2) in this grid's indices (maybe outside it)."""
        return self.world_cells(points) - np.array(self._first_cell, dtype=np.int64)

    def integrate(self, origins, ends, hits) -> None:
        """One scan's beams, (N, 2) map-frame starts and ends and (N,) bool returns: clear what they cross, mark
        the returns. Grows the grid to cover them; growth beyond max_cells is refused (ValueError), the grid
        unchanged."""
        starts, stops = self.world_cells(origins, "origins"), self.world_cells(ends, "ends")
        hits = np.asarray(hits)
        if starts.shape != stops.shape or hits.dtype != np.bool_ or hits.shape != (len(starts),) \
                or len(hits) > MAX_BEAMS:
            raise ValueError(f"origins, ends, hits: expected (N, 2), (N, 2) and (N,) bool, N <= {MAX_BEAMS}, got "
                             f"{starts.shape}, {stops.shape} and {hits.dtype} {hits.shape}")
        if len(hits) == 0:
            return
        self._cover(np.minimum(starts.min(axis=0), stops.min(axis=0)),
                    np.maximum(starts.max(axis=0), stops.max(axis=0)))
        first = np.array(self._first_cell, dtype=np.int64)
        integrate_beams(self._log_odds, starts - first, stops - first, hits, self.hit_update, self.miss_update,
                        self.low, self.high)

    def _cover(self, low_cell: np.ndarray, high_cell: np.ndarray) -> None:
        """Grow (in whole chunks) to hold the world cells low_cell..high_cell ((col, row), inclusive)."""
        chunk = self.chunk_cells
        low = (low_cell // chunk) * chunk
        high = (high_cell // chunk + 1) * chunk
        if self._log_odds.size:
            rows, cols = self._log_odds.shape
            first = np.array(self._first_cell, dtype=np.int64)
            low, high = np.minimum(low, first), np.maximum(high, first + (cols, rows))
            if (low == first).all() and (high == first + (cols, rows)).all():
                return
        cols, rows = (high - low).tolist()
        if rows * cols > self.max_cells:
            raise ValueError(f"origins, ends: the grid would grow to {rows} x {cols} cells "
                             f"({rows * self.resolution:g} m x {cols * self.resolution:g} m), beyond max_cells = "
                             f"{self.max_cells}")
        grown = np.zeros((rows, cols), dtype=np.float32)
        if self._log_odds.size:
            dc, dr = (np.array(self._first_cell) - low).tolist()
            grown[dr:dr + self._log_odds.shape[0], dc:dc + self._log_odds.shape[1]] = self._log_odds
        self._log_odds = grown
        self._first_cell = (int(low[0]), int(low[1]))

    def occupancy_map(self, occupied_threshold: float = 0.65, free_threshold: float = 0.196,
                      frame_id: str = "map") -> OccupancyMap:
        """The grid as a trinary map, like a saved one: 100 where p > occupied_threshold, 0 where
        p < free_threshold, -1 where never seen or in between."""
        for name, value in (("occupied_threshold", occupied_threshold), ("free_threshold", free_threshold)):
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ValueError(f"{name}: expected a probability, got {value!r}")
        problem = threshold_problem(occupied_threshold, free_threshold)
        if problem:
            raise ValueError(f"{problem[0].replace('thresh', 'threshold')}: {problem[1]}")
        if not isinstance(frame_id, str) or not frame_id:
            raise ValueError(f"frame_id: expected a frame name, got {frame_id!r}")
        thresholds = np.array([occupied_threshold, free_threshold], dtype=np.float64)
        with np.errstate(divide="ignore"):        # thresholds 0 and 1 are -inf and +inf in log-odds
            occupied, free = np.log(thresholds / (1.0 - thresholds))
        data = np.full(self._log_odds.shape, -1, dtype=np.int8)
        seen = self._log_odds != 0.0
        data[seen & (self._log_odds > occupied)] = 100
        data[seen & (self._log_odds < free)] = 0
        return OccupancyMap(data, self.resolution, (*self.origin, 0.0), frame_id)


def render(poses, scans, resolution: float = 0.05, **grid_kwargs) -> LogOddsGrid:
    """The map from scratch: ``scans[k]`` (a ScanPoints in the base frame) integrated at ``poses[k]`` (x, y, yaw),
    in order; what a loop closure calls for once it has moved the poses."""
    poses = np.asarray(poses)
    if poses.ndim != 2 or poses.shape[1] != 3 or poses.dtype.kind not in "iuf" or len(poses) > MAX_SCANS:
        raise ValueError(f"poses: expected an (N, 3) array of numbers, N <= {MAX_SCANS}, got {poses.dtype} "
                         f"{poses.shape}")
    poses = poses.astype(np.float64)
    if not np.isfinite(poses).all():
        raise ValueError(f"poses: row {int(np.argwhere(~np.isfinite(poses))[0, 0])} is not finite")
    scans = list(scans)
    if len(scans) != len(poses):
        raise ValueError(f"scans: expected one per pose ({len(poses)}), got {len(scans)}")
    for k, scan in enumerate(scans):
        if not isinstance(scan, ScanPoints):
            raise ValueError(f"scans[{k}]: expected a ScanPoints, got {type(scan).__name__}")
    grid = LogOddsGrid(resolution, **grid_kwargs)
    low, high = None, None
    for k, (pose, scan) in enumerate(zip(poses, scans)):    # the final extent first: one growth, not one a scan
        if len(scan):
            name = f"scans[{k}] at poses[{k}]"
            cells = np.concatenate([grid.world_cells(part, name) for part in scan.in_frame(pose)])
            low = cells.min(axis=0) if low is None else np.minimum(low, cells.min(axis=0))
            high = cells.max(axis=0) if high is None else np.maximum(high, cells.max(axis=0))
    if low is not None:
        grid._cover(low, high)
    for pose, scan in zip(poses, scans):
        grid.integrate(*scan.in_frame(pose), scan.hits)
    return grid
