"""A laser scan as SLAM keeps it: each beam's start and end in the robot's base frame, and whether it hit.

Beams that return nothing (REP-117: +inf, or beyond range_max) still clear the cells they cross, up to the mapper's
max_laser_range, so they are kept as misses. NaN, -inf and returns below range_min tell nothing and are dropped.
Both lidars' scans of one moment merge into one ScanPoints, each beam starting at its own sensor.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.geometry import transform_points

#: beams one ScanPoints may hold (two 683-beam lidars need 1366; a 16-lidar robot fits)
MAX_BEAMS = 16_384


@dataclass(frozen=True, eq=False)
class ScanPoints:
    """``origins[i]`` and ``ends[i]`` (metres, base frame) are beam i's sensor and end; ``hits[i]`` says whether
    the end is a return (else the beam saw nothing up to there)."""
    origins: np.ndarray
    ends: np.ndarray
    hits: np.ndarray

    def __post_init__(self):
        n = len(self.hits)
        for name in ("origins", "ends"):
            value = getattr(self, name)
            if not isinstance(value, np.ndarray) or value.shape != (n, 2) or value.dtype != np.float64:
                raise ValueError(f"ScanPoints.{name}: expected a float64 array of shape ({n}, 2), got "
                                 f"{getattr(value, 'dtype', type(value).__name__)} {np.shape(value)}")
            if not np.isfinite(value).all():
                raise ValueError(f"ScanPoints.{name}: every coordinate must be finite")
        if not isinstance(self.hits, np.ndarray) or self.hits.dtype != np.bool_ or self.hits.ndim != 1:
            raise ValueError("ScanPoints.hits: expected a 1-D bool array")
        if n > MAX_BEAMS:
            raise ValueError(f"ScanPoints: at most {MAX_BEAMS} beams, got {n}")

    def __len__(self) -> int:
        return len(self.hits)

    @property
    def returns(self) -> np.ndarray:
        """(M, 2) the ends that are returns: what a scan matcher aligns."""
        return self.ends[self.hits]

    @functools.cached_property
    def sensors(self) -> np.ndarray:
        """(K, 2) the distinct sensor positions (base frame): a robot's few lidars."""
        origins = self.origins
        changes = np.concatenate([[True], (origins[1:] != origins[:-1]).any(axis=1)]) if len(origins) else []
        return np.unique(origins[changes], axis=0)

    def surfaces(self, max_gap: float, spacing: float) -> np.ndarray:
        """(M', 2) the returns with the surfaces between them filled in: between two neighbouring beams of one sensor
        whose returns lie at most ``max_gap`` apart (one surface, not a wall and what lies behind its edge), points
        at most ``spacing`` apart. A wall seen at a grazing angle is a row of returns far apart; a matcher's field
        drawn from them alone has gaps, and a scan moved to where the field is denser scores better."""
        ends, hits, origins = self.ends, self.hits, self.origins
        pair = hits[:-1] & hits[1:] & (origins[:-1] == origins[1:]).all(axis=1)
        gaps = np.hypot(*(ends[1:] - ends[:-1]).T)
        pair &= (gaps <= max_gap) & (gaps > spacing)
        first = np.flatnonzero(pair)
        if len(first) == 0:
            return self.returns
        steps = np.ceil(gaps[first] / spacing).astype(np.int64)        # pieces per gap; steps - 1 points inside
        owner = np.repeat(np.arange(len(first)), steps - 1)
        k = np.arange(len(owner)) - np.repeat(np.cumsum(steps - 1) - (steps - 1), steps - 1) + 1
        t = (k / steps[owner])[:, None]
        a, b = ends[first[owner]], ends[first[owner] + 1]
        return np.concatenate([self.returns, a + t * (b - a)])

    def in_frame(self, pose) -> tuple[np.ndarray, np.ndarray]:
        """(origins, ends) moved by ``pose`` (x, y, yaw): the base frame's points in the frame the pose is in."""
        return transform_points(pose, self.origins), transform_points(pose, self.ends)

    @staticmethod
    def merged(parts: list[ScanPoints]) -> ScanPoints:
        if not parts:
            return ScanPoints(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, dtype=bool))
        return ScanPoints(np.concatenate([p.origins for p in parts]), np.concatenate([p.ends for p in parts]),
                          np.concatenate([p.hits for p in parts]))


def scan_points(ranges, angle_min: float, angle_increment: float, range_min: float, range_max: float,
                sensor_pose, max_laser_range: float) -> ScanPoints:
    """The beams of one LaserScan whose frame sits at ``sensor_pose`` (x, y, yaw) in the base frame.

    A return beyond ``max_laser_range`` (slam_toolbox's parameter: returns further than this are not trusted)
    becomes a miss at that range, as does +inf or anything beyond range_max."""
    ranges = np.asarray(ranges, dtype=np.float64)
    if ranges.ndim != 1 or not 1 <= len(ranges) <= MAX_BEAMS:
        raise ValueError(f"ranges: 1 to {MAX_BEAMS} beams, got shape {ranges.shape}")
    for name, value in (("angle_min", angle_min), ("angle_increment", angle_increment), ("range_min", range_min),
                        ("range_max", range_max), ("max_laser_range", max_laser_range)):
        if not math.isfinite(value):
            raise ValueError(f"{name}: must be finite, got {value!r}")
    if angle_increment == 0.0 or abs(angle_increment * len(ranges)) > 2 * math.pi + 1e-6:
        raise ValueError(f"angle_increment: {angle_increment!r} over {len(ranges)} beams is zero or more than a turn")
    if not 0.0 <= range_min < range_max or max_laser_range <= 0.0:
        raise ValueError(f"range_min / range_max / max_laser_range: need 0 <= range_min < range_max and "
                         f"max_laser_range > 0, got {range_min!r} / {range_max!r} / {max_laser_range!r}")
    if len(sensor_pose) != 3 or not all(math.isfinite(v) for v in sensor_pose):
        raise ValueError(f"sensor_pose: expected finite (x, y, yaw), got {sensor_pose!r}")
    reach = min(range_max, max_laser_range)
    with np.errstate(invalid="ignore"):
        hits = np.isfinite(ranges) & (ranges >= range_min) & (ranges <= reach)
        misses = (ranges == np.inf) | (np.isfinite(ranges) & (ranges > reach))
    keep = hits | misses
    lengths = np.where(hits, ranges, reach)[keep]
    angles = sensor_pose[2] + angle_min + angle_increment * np.flatnonzero(keep)
    ends = np.column_stack((sensor_pose[0] + lengths * np.cos(angles), sensor_pose[1] + lengths * np.sin(angles)))
    origins = np.broadcast_to(np.array(sensor_pose[:2], dtype=np.float64), ends.shape).copy()
    return ScanPoints(origins, ends, hits[keep].copy())
