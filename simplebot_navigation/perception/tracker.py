"""ObstacleTracker: clusters of lidar returns followed over time by constant-velocity Kalman filters
(docs/reference.md §6).

Per update (one scan, or the scans taken together): predict every track to the stamp, cut each scan into
clusters, assign clusters to tracks (Hungarian on centre distance, gated), update the tracks whose cluster is
whole, let the rest coast, start tentative tracks from unassigned clusters, delete tracks that visible scans
keep missing, and judge which tracks move. Clusters wider than max_obstacle_size are walls and never tracked.
A cluster with an occluded end updates only the track's life, never its motion: the visible part of a wall
behind a passing person shrinks and grows, and that must not read as velocity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from simplebot_navigation.perception import kalman
from simplebot_navigation.perception.params import TrackerParams
from simplebot_navigation.perception.segmentation import Clusters, Scan, segment
from simplebot_navigation.perception.structure import StructureMap
from simplebot_navigation.perception.trail import ClearingTrail

#: how fast a track's radius follows its clusters' (exponential smoothing factor)
RADIUS_SMOOTHING = 0.3
#: a new cluster this close to an existing track's outline is a fragment of it, not a new track
FRAGMENT_MARGIN = 0.1
#: the smallest radius reported
MIN_RADIUS = 0.05
#: a cluster with this share of its returns on structure is structure
STRUCTURE_SHARE = 0.5


@dataclass(frozen=True)
class Track:
    """One tracked obstacle in the tracking frame, as of `stamp`."""
    id: int
    position: np.ndarray          # (2,)
    velocity: np.ndarray          # (2,)
    covariance: np.ndarray        # (4, 4) over x, y, vx, vy
    radius: float
    age: float                    # seconds since it was first seen
    confirmed: bool
    moving: bool
    stamp: float


_FIELDS = ("ids", "state", "cov", "radius", "born", "last_seen", "hits", "missed", "confirmed", "moving",
           "since", "motion_updates", "on_structure")


class ObstacleTracker:
    """``update(scans, stamp)`` per scan (or scan pair); ``tracks()``, ``moving_obstacles(now)`` and
    ``clearing_circles(now)`` between updates. Not thread-safe: the ROS shell calls it from one thread."""

    def __init__(self, params: TrackerParams | None = None):
        self.params = params or TrackerParams()
        self.trail = ClearingTrail(self.params.clearing_time)
        self.structure = StructureMap(self.params.structure_time)
        self.reset()

    def reconfigure(self, params: TrackerParams) -> None:
        """New parameters from the next update on; the tracks stay."""
        self.params = params
        self.trail.keep = params.clearing_time
        self.structure.time_constant = params.structure_time

    def reset(self) -> None:
        """Forget every track (time jumped back, tracking switched off)."""
        self.ids = np.empty(0, dtype=np.int64)
        self.state = np.empty((0, 4))
        self.cov = np.empty((0, 4, 4))
        self.radius = np.empty(0)
        self.born = np.empty(0)
        self.last_seen = np.empty(0)
        self.hits = np.empty(0, dtype=np.int64)
        self.missed = np.empty(0, dtype=np.int64)
        self.confirmed = np.empty(0, dtype=bool)
        self.moving = np.empty(0, dtype=bool)
        self.since = np.empty(0)                  # when the moving flag's opposite condition began (nan: not)
        self.motion_updates = np.empty(0, dtype=np.int64)   # whole-cluster updates of the filter
        self.on_structure = np.empty(0, dtype=bool)         # its last cluster lay on structure
        self.stamp: float | None = None
        self._next_id = 0
        self.trail.clear()
        self.structure.clear()

    # -- the update --------------------------------------------------------------------------
    def update(self, scans: list[Scan], stamp: float) -> bool:
        """Take the scans taken at `stamp`; False (nothing changes) when stamp is older than the last one."""
        stamp = float(stamp)
        if self.stamp is not None and stamp < self.stamp:
            return False
        p = self.params
        kalman.predict(self.state, self.cov, 0.0 if self.stamp is None else stamp - self.stamp,
                       np.where(self.moving, p.acceleration_noise, p.static_acceleration_noise))
        self.stamp = stamp
        on_structure = np.split(self.structure.update(
            np.concatenate([s.points() for s in scans]) if scans else np.empty((0, 2)), stamp,
            np.mean([s.origin for s in scans], axis=0) if scans else np.full(2, np.nan)),
            np.cumsum([len(s.ranges) for s in scans])[:-1])
        clusters = Clusters.concatenate([segment(s, p.breakpoint_angle, p.breakpoint_distance, p.range_noise,
                                                 p.min_points, flags) for s, flags in zip(scans, on_structure)])
        clusters = clusters.select(clusters.width <= p.max_obstacle_size)
        track_of, cluster_of = self._associate(clusters)
        self._correct(clusters, track_of, cluster_of, stamp)
        self._forget_missed(scans, track_of, stamp)
        self._start_tracks(clusters, cluster_of, stamp)
        self._judge_motion(stamp)
        live = self.confirmed
        self.trail.add(stamp, self.ids[live], np.column_stack([self.state[live, :2], self.radius[live]]),
                       self.ids[live & self.moving])
        return True

    def _associate(self, clusters: Clusters) -> tuple[np.ndarray, np.ndarray]:
        """track_of[k]: the track index cluster k updates (-1: none); cluster_of[t] the reverse."""
        track_of = np.full(len(clusters), -1)
        cluster_of = np.full(len(self.ids), -1)
        if not len(clusters) or not len(self.ids):
            return track_of, cluster_of
        distance = np.hypot(*(self.state[:, None, :2] - clusters.centre[None, :, :]).transpose(2, 0, 1))
        gate = self.params.association_gate
        # Both lidars may see one obstacle, one of them cut at its field's edge: a whole outline wins the
        # track, as only whole ones correct the filter.
        cost = distance + gate * clusters.occluded[None, :]
        rows, cols = linear_sum_assignment(np.where(distance <= gate, cost, gate * 1e3))
        ok = distance[rows, cols] <= gate
        cluster_of[rows[ok]] = cols[ok]
        track_of[cols[ok]] = rows[ok]
        return track_of, cluster_of

    def _correct(self, clusters: Clusters, track_of: np.ndarray, cluster_of: np.ndarray, stamp: float) -> None:
        seen = cluster_of >= 0
        self.last_seen[seen] = stamp
        self.on_structure[seen] = clusters.structure[cluster_of[seen]] >= STRUCTURE_SHARE
        self.hits[seen] += 1
        self.missed[seen] = 0
        matched = cluster_of[seen]
        # A cut outline shows only part of the obstacle: it may make a track larger, never smaller.
        observed = np.maximum(clusters.radius[matched], MIN_RADIUS)
        observed = np.where(clusters.occluded[matched], np.maximum(observed, self.radius[seen]), observed)
        self.radius[seen] += RADIUS_SMOOTHING * (observed - self.radius[seen])
        whole = np.flatnonzero(seen)[~clusters.occluded[matched]]
        if len(whole):
            state, cov = self.state[whole], self.cov[whole]
            kalman.update(state, cov, clusters.centre[cluster_of[whole]], self.params.measurement_noise)
            self.state[whole], self.cov[whole] = state, cov
            self.motion_updates[whole] += 1
        self.confirmed |= self.hits >= self.params.confirm_hits

    def _forget_missed(self, scans: list[Scan], track_of: np.ndarray, stamp: float) -> None:
        """A track no scan matched counts a miss if some scan should have seen it; too many misses, a tentative
        track's first miss, or too long unseen delete it."""
        unmatched = np.flatnonzero(self.last_seen < stamp)
        if len(unmatched):
            visible = np.zeros(len(unmatched), dtype=bool)
            for scan in scans:
                visible |= _visible(scan, self.state[unmatched, :2], self.radius[unmatched])
            self.missed[unmatched[visible]] += 1
        p = self.params
        drop = (self.missed >= p.max_missed) | ((self.missed > 0) & ~self.confirmed) | \
            (stamp - self.last_seen > p.max_coast_time)
        if drop.any():
            self._keep(~drop)

    def _start_tracks(self, clusters: Clusters, cluster_of: np.ndarray, stamp: float) -> None:
        fresh = clusters.structure < STRUCTURE_SHARE
        fresh[cluster_of[cluster_of >= 0]] = False
        if len(self.ids) and fresh.any():
            distance = np.hypot(*(clusters.centre[:, None, :] - self.state[None, :, :2]).transpose(2, 0, 1))
            fresh &= ~(distance < self.radius[None, :] + clusters.radius[:, None] + FRAGMENT_MARGIN).any(axis=1)
        new = clusters.select(fresh)
        n = len(new)
        if not n:
            return
        p = self.params
        self._append(ids=np.arange(self._next_id, self._next_id + n),
                     state=np.column_stack([new.centre, np.zeros((n, 2))]),
                     cov=kalman.initial_covariance(n, p.measurement_noise, p.initial_speed_sigma),
                     radius=np.maximum(new.radius, MIN_RADIUS), born=np.full(n, stamp), last_seen=np.full(n, stamp),
                     hits=np.ones(n, dtype=np.int64), missed=np.zeros(n, dtype=np.int64),
                     confirmed=np.full(n, p.confirm_hits <= 1), moving=np.zeros(n, dtype=bool),
                     since=np.full(n, np.nan), motion_updates=(~new.occluded).astype(np.int64),
                     on_structure=np.zeros(n, dtype=bool))
        self._next_id += n

    def _judge_motion(self, stamp: float) -> None:
        """The moving flag flips once the opposite condition has held for moving_hold: above moving_speed by one
        sigma (with a filter that has seen enough whole clusters, off structure) to turn moving, below static_speed
        to stop."""
        p = self.params
        speed, sigma = kalman.speed_and_sigma(self.state, self.cov)
        fast = self.confirmed & (self.motion_updates >= p.confirm_hits) & (speed - sigma > p.moving_speed) & \
            ~self.on_structure
        opposite = np.where(self.moving, speed < p.static_speed, fast)
        self.since = np.where(opposite, np.where(np.isnan(self.since), stamp, self.since), np.nan)
        flip = opposite & (stamp - self.since >= p.moving_hold)
        self.moving ^= flip
        self.since[flip] = np.nan

    def _keep(self, mask: np.ndarray) -> None:
        for name in _FIELDS:
            setattr(self, name, getattr(self, name)[mask])

    def _append(self, **rows) -> None:
        for name in _FIELDS:
            setattr(self, name, np.concatenate([getattr(self, name), rows[name]]))

    # -- results -----------------------------------------------------------------------------
    def tracks(self, include_tentative: bool = False) -> list[Track]:
        """Every confirmed track (and the tentative ones too, if asked) as of the last update."""
        out = []
        for i in np.flatnonzero(self.confirmed | include_tentative):
            out.append(Track(int(self.ids[i]), self.state[i, :2].copy(), self.state[i, 2:].copy(), self.cov[i].copy(),
                             float(self.radius[i]), float(self.stamp - self.born[i]), bool(self.confirmed[i]),
                             bool(self.moving[i]), float(self.stamp)))
        return out

    def moving_obstacles(self, now: float | None = None) -> np.ndarray:
        """Rows [x, y, vx, vy, radius] of the moving tracks, positions extrapolated to `now` (default: the last
        update's stamp)."""
        moving = self.confirmed & self.moving
        if not moving.any():
            return np.empty((0, 5))
        dt = 0.0 if now is None or self.stamp is None else float(now) - self.stamp
        state = self.state[moving]
        return np.column_stack([state[:, :2] + dt * state[:, 2:], state[:, 2:], self.radius[moving]])

    def moving_covariances(self, now: float | None = None) -> np.ndarray:
        """(K, 4, 4) covariances over x, y, vx, vy of the rows of moving_obstacles, propagated to `now` by the
        motion model alone (no process noise)."""
        moving = self.confirmed & self.moving
        cov = self.cov[moving].copy()
        dt = 0.0 if now is None or self.stamp is None else max(float(now) - self.stamp, 0.0)
        f = np.eye(4)
        f[0, 2] = f[1, 3] = dt
        return f @ cov @ f.T

    def moving_ids(self) -> np.ndarray:
        """The ids of the rows of moving_obstacles, in the same order."""
        return self.ids[self.confirmed & self.moving]

    def clearing_circles(self, now: float) -> np.ndarray:
        """(K, 3) circles x, y, r where moving tracks were within clearing_time of `now`, plus where they are
        now, each radius widened by clearing_margin: the marks the costmaps should clear."""
        now_rows = self.moving_obstacles(now)[:, [0, 1, 4]]
        now_rows[:, 2] += self.params.clearing_margin
        return np.concatenate([self.trail.circles(now, self.params.clearing_margin), now_rows])


def _visible(scan: Scan, centres: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Whether a scan should have seen each object: within its field of view and range, with the beam towards
    its centre reaching it (not stopped by something nearer, nor lost)."""
    step = scan.angles[1] - scan.angles[0] if len(scan.angles) > 1 else 0.0
    if not step or not len(centres):
        return np.zeros(len(centres), dtype=bool)
    offset = centres - scan.origin
    distance = np.hypot(offset[:, 0], offset[:, 1])
    bearing = np.arctan2(offset[:, 1], offset[:, 0])
    span = ((bearing - scan.angles[0]) * np.sign(step)) % (2 * np.pi)
    index = np.round(span / abs(step)).astype(np.int64)
    inside = (index >= 0) & (index < len(scan.angles)) & (distance + radius < scan.range_max) & \
        (distance - radius > scan.range_min)
    with np.errstate(invalid="ignore"):
        beyond = scan.ranges >= scan.range_max                  # +inf too: nothing there
    reach = np.where(scan.valid(), scan.ranges, np.where(beyond, np.inf, -np.inf))   # NaN: no information
    beam = np.clip(index, 0, len(scan.angles) - 1)
    return inside & (reach[beam] >= distance - radius - FRAGMENT_MARGIN)
