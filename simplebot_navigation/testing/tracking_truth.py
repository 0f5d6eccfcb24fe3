"""What the obstacle tracker reports, matched to the simulator's ground truth (bench/tracking_truth.py,
tests/perception).

The scans are taken from the lidars' true poses in the world frame, so the tracker works in the world frame and
its tracks compare with the moving obstacles' true states directly. A moving obstacle is *in sight* in a scan when
the beam of some lidar towards its centre ends on its near side: within that lidar's field of view and range, and
not hidden behind anything (another obstacle, a wall). A *sighting* is a stretch of scans with it in sight, gaps up
to LOST_AFTER_S included; its *verdict* is the first scan at which a moving track lies within MATCH_GATE_M of its
centre. A sighting that ends (out of sight for longer than LOST_AFTER_S) without a verdict is *lost*.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np

from simplebot_navigation.perception import Scan

MATCH_GATE_M = 0.6
LOST_AFTER_S = 0.5
#: a beam towards an obstacle's centre that ends this near its near side ends on it
ON_OUTLINE_M = 0.1
#: the band of gaps (between the robot's outline and the obstacle's) where a verdict matters most
BAND_M = (0.8, 2.5)
#: a false moving track lasting longer than this is one the planners would act on
LASTING_S = 0.5


def scans_in_world(sim, description) -> list[Scan]:
    """The scans due now, as seen from each lidar's true pose in the world frame."""
    truth = sim.ground_truth()
    out = []
    for data in sim.due_scans():
        lx, ly, _, lyaw = description.laser_poses[data.frame]
        c, s = math.cos(truth.yaw), math.sin(truth.yaw)
        out.append(Scan.from_laser(data.ranges, data.angle_min, data.angle_increment, data.range_min,
                                   data.range_max, truth.x + c * lx - s * ly, truth.y + s * lx + c * ly,
                                   truth.yaw + lyaw))
    return out


def visible(position, robot_xy, others) -> bool:
    """Not hidden behind another moving obstacle on the line of sight (a rough test: its centre line)."""
    to = position - robot_xy
    dist = float(np.hypot(*to))
    for centre, radius in others:
        rel = centre - robot_xy
        along = float(rel @ to) / dist
        if 0.0 < along < dist and abs(float(to[0] * rel[1] - to[1] * rel[0])) / dist < radius:
            return False
    return True


def outline_radius(extent) -> float:
    """A cylinder's radius, or the radius of the circle a box's (sx, sy) fits in."""
    return float(extent) if np.isscalar(extent) else 0.5 * math.hypot(*extent)


def in_sight(scans: list[Scan], centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """(K,) whether some scan's beam towards each centre ends on the near side of the circle around it."""
    seen = np.zeros(len(centres), dtype=bool)
    for scan in scans:
        if len(scan.angles) < 2 or not len(centres):
            continue
        step = scan.angles[1] - scan.angles[0]
        offset = centres - scan.origin
        bearing = np.arctan2(offset[:, 1], offset[:, 0])
        index = np.round(((bearing - scan.angles[0]) * np.sign(step)) % math.tau / abs(step)).astype(np.int64)
        inside = index < len(scan.angles)
        beam = np.minimum(index, len(scan.angles) - 1)
        near_side = np.hypot(offset[:, 0], offset[:, 1]) - radii
        seen |= inside & scan.valid()[beam] & (np.abs(scan.ranges[beam] - near_side) <= ON_OUTLINE_M)
    return seen


def _percentiles(values, qs=(50, 90)) -> tuple[float, ...]:
    return tuple(float(np.percentile(values, q)) if len(values) else math.nan for q in qs)


@dataclass
class _Sighting:
    start: float
    last_seen: float
    verdict: float | None = None


@dataclass
class CrowdScore:
    """Verdict latencies, the band's shares and the errors of the matched moving tracks over a run."""
    latencies: list[float] = field(default_factory=list)   # s, of sightings that began without a moving track
    kept: int = 0               # sightings with a moving track from their first scan (it outlived a gap)
    lost: int = 0
    open_at_end: int = 0        # sightings without a verdict when the run ended: neither lost nor judged
    band: dict = field(default_factory=lambda: {"moving": 0, "static": 0, "none": 0})
    position_errors: list[float] = field(default_factory=list)
    velocity_errors: list[float] = field(default_factory=list)
    _open: dict = field(default_factory=dict)

    def add(self, stamp: float, robot_xy, robot_radius: float, states, seen: np.ndarray, tracks) -> None:
        """One scan: the obstacles' true states, which are in sight, and the tracker's (confirmed) tracks."""
        if not states:
            return
        centres = np.array([[s.x, s.y] for s in states])
        moving = [t for t in tracks if t.moving]
        to_moving = _distances(centres, moving)
        nearest = np.argmin(to_moving, axis=1) if moving else np.zeros(len(states), dtype=np.int64)
        matched = to_moving.min(axis=1, initial=math.inf) <= MATCH_GATE_M
        for k, state in enumerate(states):
            self._follow(state.label, stamp, bool(seen[k]), bool(matched[k]))
        radii = np.array([outline_radius(s.extent) for s in states])
        gap = np.hypot(*(centres - np.asarray(robot_xy)).T) - radii - robot_radius
        in_band = seen & (gap >= BAND_M[0]) & (gap <= BAND_M[1])
        near_static = _distances(centres, [t for t in tracks if not t.moving]).min(axis=1, initial=math.inf) \
            <= MATCH_GATE_M
        self.band["moving"] += int((in_band & matched).sum())
        self.band["static"] += int((in_band & ~matched & near_static).sum())
        self.band["none"] += int((in_band & ~matched & ~near_static).sum())
        for k in np.flatnonzero(seen & matched):
            track = moving[nearest[k]]
            self.position_errors.append(float(to_moving[k, nearest[k]]))
            self.velocity_errors.append(float(np.hypot(*(track.velocity - (states[k].vx, states[k].vy)))))

    def _follow(self, label: str, stamp: float, seen: bool, matched: bool) -> None:
        sighting = self._open.get(label)
        if sighting is not None and stamp - sighting.last_seen > LOST_AFTER_S:
            self.lost += sighting.verdict is None
            del self._open[label]
            sighting = None
        if seen:
            if sighting is None:
                sighting = self._open[label] = _Sighting(stamp, stamp)
                if matched:
                    sighting.verdict = stamp
                    self.kept += 1
            sighting.last_seen = stamp
        if sighting is not None and matched and sighting.verdict is None:
            sighting.verdict = stamp
            self.latencies.append(stamp - sighting.start)

    def finish(self) -> None:
        """The run ended: sightings still waiting for a verdict are counted as open, not lost."""
        self.open_at_end += sum(s.verdict is None for s in self._open.values())
        self._open.clear()

    def merge(self, other: CrowdScore) -> None:
        self.latencies += other.latencies
        self.kept, self.lost, self.open_at_end = (self.kept + other.kept, self.lost + other.lost,
                                                  self.open_at_end + other.open_at_end)
        for key in self.band:
            self.band[key] += other.band[key]
        self.position_errors += other.position_errors
        self.velocity_errors += other.velocity_errors

    def summary(self) -> dict:
        """The numbers a table prints (NaN where there was nothing to measure)."""
        judged = len(self.latencies) + self.lost
        samples = sum(self.band.values())
        return {"sightings": judged + self.kept + self.open_at_end, "kept": self.kept,
                "latency_s": _percentiles(self.latencies),
                "lost_share": self.lost / judged if judged else math.nan,
                "band_samples": samples,
                "band_share": {k: v / samples if samples else math.nan for k, v in self.band.items()},
                "position_error_m": _percentiles(self.position_errors),
                "velocity_error_m_s": _percentiles(self.velocity_errors),
                "matched_samples": len(self.velocity_errors)}


def _distances(centres: np.ndarray, tracks) -> np.ndarray:
    """(K, M) distances from each centre to each track's position."""
    if not tracks:
        return np.empty((len(centres), 0))
    positions = np.array([t.position for t in tracks])
    return np.hypot(*(centres[:, None, :] - positions[None, :, :]).transpose(2, 0, 1))


@dataclass
class FalseMotion:
    """Moving tracks where nothing moves: how long each track was reported moving (over the scans' periods)."""
    moving_s: dict = field(default_factory=lambda: defaultdict(float))     # this run's, by track id
    other_runs_s: list = field(default_factory=list)

    def add(self, period: float, tracks) -> None:
        for track in tracks:
            if track.moving:
                self.moving_s[track.id] += period

    def merge(self, other: FalseMotion) -> None:
        self.other_runs_s += other.other_runs_s + list(other.moving_s.values())

    def summary(self) -> dict:
        durations = np.array(self.other_runs_s + list(self.moving_s.values()))
        return {"moving_tracks": len(durations), "lasting": int((durations > LASTING_S).sum()),
                "total_s": float(durations.sum())}
