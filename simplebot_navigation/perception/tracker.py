"""ObstacleTracker: clusters of lidar returns followed over time by interacting multiple model filters
(docs/reference.md §6).

Per update (one scan, or the scans taken together): predict every track to the stamp, cut each scan into
clusters, assign clusters to tracks (Hungarian on centre distance, gated by each track's uncertainty), correct the
tracks, start a track at first sight from each unassigned cluster, delete tracks that visible scans keep missing,
and judge which tracks move. Clusters wider than max_obstacle_size are walls and never tracked. A track's second
sighting sets its velocity from the displacement; from then on a filter mixing a stopped, a steady and a
manoeuvring model follows it. A whole cluster measures the centre; a cut one (occluded) by a circle fitted to
the visible arc.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import linear_sum_assignment

from simplebot_navigation.perception import kalman, tracking_kernels
from simplebot_navigation.perception.params import TrackerParams
from simplebot_navigation.perception.segmentation import (FIT_DAMPING, FIT_ITERATIONS, FIXED_INFORMATION, Clusters,
                                                          Scan, segment)
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
#: the association gate widens by this many sigmas of a track's position, up to MAX_GATE
GATE_SIGMAS, MAX_GATE = 2.0, 1.5
#: a cut cluster whose returns lie farther than this (RMS) from the circle fitted to them is no arc of the track
FIT_RMS = 0.02
#: a fitted centre counts no closer than this (1 sigma, metres) in any direction
FIT_FLOOR = 0.01
#: a radius fitted to a cut outline counts when its sigma is at most this (metres)
FIT_RADIUS_SIGMA = 0.05
#: a fitted centre is used within this normalised squared distance of the prediction (chi-square, 2 dof: 99 %)
FIT_GATE = 9.21
#: a track turns moving only while its stopped model's probability is below this
STOPPED_BELOW = 0.5


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


_FIELDS = ("ids", "models", "model_covs", "probs", "state", "cov", "radius", "radius_known", "born", "origin", "last_seen",
           "last_fix", "hits", "missed", "confirmed", "moving", "since", "velocity_updates", "on_structure")


class ObstacleTracker:
    """``update(scans, stamp)`` per scan (or scan pair); ``tracks()``, ``moving_obstacles(now)``,
    ``moving_covariances(now)`` and ``clearing_circles(now)`` between updates. Not thread-safe: the ROS shell calls
    it from one thread."""

    def __init__(self, params: TrackerParams | None = None):
        self.params = params or TrackerParams()
        self.trail = ClearingTrail(self.params.clearing_time)
        self.structure = StructureMap(self.params.structure_time)
        self.static_cells: Callable[[np.ndarray], np.ndarray] | None = None
        self.reset()

    def reconfigure(self, params: TrackerParams) -> None:
        """New parameters from the next update on; the tracks stay."""
        self.params = params
        self.trail.keep = params.clearing_time
        self.structure.time_constant = params.structure_time

    def set_static_cells(self, static_cells: Callable[[np.ndarray], np.ndarray] | None) -> None:
        """What is known to be static (a map's marks): a callable taking (N, 2) points in the tracking frame and
        returning (N,) whether each lies on a static mark (structure.StaticCells is one); None: nothing known.
        Returns on it count as structure: their clusters start no track and turn no track moving."""
        self.static_cells = static_cells

    def reset(self) -> None:
        """Forget every track (time jumped back, tracking switched off)."""
        self.ids = np.empty(0, dtype=np.int64)
        self.models = np.empty((0, kalman.MODELS, 4))           # each motion model's state
        self.model_covs = np.empty((0, kalman.MODELS, 4, 4))
        self.probs = np.empty((0, kalman.MODELS))
        self.state = np.empty((0, 4))                           # the models combined
        self.cov = np.empty((0, 4, 4))
        self.radius = np.empty(0)
        self.radius_known = np.empty(0, dtype=bool)             # seen whole at least once
        self.born = np.empty(0)
        self.origin = np.empty((0, 2))                          # where it was first seen
        self.last_seen = np.empty(0)
        self.last_fix = np.empty(0)                             # stamp of its last position measurement
        self.hits = np.empty(0, dtype=np.int64)
        self.missed = np.empty(0, dtype=np.int64)
        self.confirmed = np.empty(0, dtype=bool)
        self.moving = np.empty(0, dtype=bool)
        self.since = np.empty(0)                  # when the moving flag's opposite condition began (nan: not)
        self.velocity_updates = np.empty(0, dtype=np.int64)     # displacements measured (0: no velocity yet)
        self.on_structure = np.empty(0, dtype=bool)             # its last cluster lay on structure
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
        self._predict(0.0 if self.stamp is None else stamp - self.stamp)
        self.stamp = stamp
        points = np.concatenate([s.points() for s in scans]) if scans else np.empty((0, 2))
        flags = self.structure.update(points, stamp, np.mean([s.origin for s in scans], axis=0) if scans
                                      else np.full(2, np.nan))
        if self.static_cells is not None and len(points):
            known = np.zeros(len(points), dtype=bool)
            finite = np.isfinite(points).all(axis=1)
            known[finite] = np.asarray(self.static_cells(points[finite]), dtype=bool)
            flags |= known
        offsets = np.concatenate([[0], np.cumsum([len(s.ranges) for s in scans])]).astype(np.int64)
        clusters = Clusters.concatenate([segment(s, p.breakpoint_angle, p.breakpoint_distance, p.range_noise,
                                                 p.min_points, flags[offsets[i]:offsets[i + 1]], int(offsets[i]))
                                         for i, s in enumerate(scans)])
        clusters = clusters.select(clusters.width <= p.max_obstacle_size)
        track_of, cluster_of = self._associate(clusters)
        self._correct(clusters, cluster_of, points, stamp)
        self._forget_missed(scans, stamp)
        self._start_tracks(clusters, cluster_of, stamp)
        self._judge_motion(stamp)
        live = self.confirmed
        self.trail.add(stamp, self.ids[live], np.column_stack([self.state[live, :2], self.radius[live]]),
                       self.ids[live & self._clearing()])
        return True

    def _predict(self, dt: float) -> None:
        """Every track with a velocity to dt later; a track seen once stays where it was seen."""
        going = self.velocity_updates > 0
        if dt <= 0.0 or not going.any():
            return
        models, covs, probs = self.models[going], self.model_covs[going], self.probs[going]
        tracking_kernels.imm_predict(models, covs, probs, *kalman.model_matrices(dt, self.params.acceleration_noise,
                                                                                 self.params.manoeuvre_noise))
        self.models[going], self.model_covs[going], self.probs[going] = models, covs, probs
        self.state[going], self.cov[going] = tracking_kernels.imm_combine(models, covs, probs)

    def _associate(self, clusters: Clusters) -> tuple[np.ndarray, np.ndarray]:
        """track_of[k]: the track index cluster k updates (-1: none); cluster_of[t] the reverse."""
        track_of = np.full(len(clusters), -1)
        cluster_of = np.full(len(self.ids), -1)
        if not len(clusters) or not len(self.ids):
            return track_of, cluster_of
        distance = np.hypot(*(self.state[:, None, :2] - clusters.centre[None, :, :]).transpose(2, 0, 1))
        gate = self._gates()[:, None]
        # Both lidars may see one obstacle, one of them cut at its field's edge: a whole outline wins the track.
        cost = distance + self.params.association_gate * clusters.occluded[None, :]
        rows, cols = linear_sum_assignment(np.where(distance <= gate, cost, MAX_GATE * 1e3))
        ok = distance[rows, cols] <= gate[rows, 0]
        cluster_of[rows[ok]] = cols[ok]
        track_of[cols[ok]] = rows[ok]
        return track_of, cluster_of

    def _gates(self) -> np.ndarray:
        """Each track's association gate: association_gate widened by its position's uncertainty (a track seen
        once: how far initial_speed_sigma takes it since)."""
        p = self.params
        sigma = np.sqrt(np.maximum(self.cov[:, 0, 0], self.cov[:, 1, 1]))
        unset = self.velocity_updates == 0
        sigma[unset] = p.initial_speed_sigma * (self.stamp - self.last_fix[unset])
        return np.minimum(p.association_gate + GATE_SIGMAS * sigma, max(MAX_GATE, p.association_gate))

    def _position_covs(self, tracks: np.ndarray) -> np.ndarray:
        """(M, 2, 2) predicted position covariances (a track seen once: grown by initial_speed_sigma since)."""
        cov = self.cov[tracks, :2, :2].copy()
        unset = self.velocity_updates[tracks] == 0
        grown = (self.params.initial_speed_sigma * (self.stamp - self.last_fix[tracks[unset]])) ** 2
        cov[unset] += grown[:, None, None] * np.eye(2)
        return cov

    def _correct(self, clusters: Clusters, cluster_of: np.ndarray, points: np.ndarray, stamp: float) -> None:
        seen = cluster_of >= 0
        self.last_seen[seen] = stamp
        self.on_structure[seen] = (clusters.structure[cluster_of[seen]] >= STRUCTURE_SHARE) | \
            clusters.unfit[cluster_of[seen]]
        self.hits[seen] += 1
        self.missed[seen] = 0
        matched = cluster_of[seen]
        whole = ~clusters.occluded[matched]
        # A cut outline shows only part of the obstacle: it may make a track larger, never smaller.
        observed = np.maximum(clusters.radius[matched], MIN_RADIUS)
        observed = np.where(whole, observed, np.maximum(observed, self.radius[seen]))
        self.radius[seen] += RADIUS_SMOOTHING * (observed - self.radius[seen])
        self.radius_known[np.flatnonzero(seen)[whole]] = True
        tracks, measured, noise = self._measurements(clusters, cluster_of, points)
        self._fix(tracks, measured, noise, stamp)
        self.confirmed |= self.hits >= self.params.confirm_hits

    def _measurements(self, clusters: Clusters, cluster_of: np.ndarray, points: np.ndarray):
        """(tracks, centres (M, 2), covariances (M, 2, 2)) that this update measures: a whole cluster's centre,
        and for one cut by something clearly nearer or the field's edge the circle fitted to its returns, of the track's radius once that is known, else of
        the radius that fits (kept when the arc fixes it to FIT_RADIUS_SIGMA)."""
        seen = np.flatnonzero(cluster_of >= 0)
        occluded = clusters.occluded[cluster_of[seen]]
        whole, cut = seen[~occluded], seen[occluded & ~clusters.unfit[cluster_of[seen]]]
        sigma2 = self.params.measurement_noise ** 2
        measured = [clusters.centre[cluster_of[whole]]]
        noise = [np.broadcast_to(np.eye(2) * sigma2, (len(whole), 2, 2))]
        if len(cut):
            k, known = cluster_of[cut], self.radius_known[cut]
            centre, cov, radius, radius_sigma, rms = tracking_kernels.fit_circles(
                points, clusters.first[k], clusters.last[k], self.radius[cut], known, self.state[cut, :2],
                max(self.params.range_noise, FIT_FLOOR), FIT_ITERATIONS, FIT_DAMPING, FIXED_INFORMATION)
            good = (rms <= FIT_RMS) & np.isfinite(centre).all(axis=1) & (radius_sigma <= FIT_RADIUS_SIGMA) & \
                (radius >= MIN_RADIUS) & (radius <= 0.5 * self.params.max_obstacle_size) & \
                (_normalised_squared(centre - self.state[cut, :2], self._position_covs(cut) + cov) <= FIT_GATE)
            learnt = cut[good & ~known]
            self.radius[learnt], self.radius_known[learnt] = radius[good & ~known], True
            cut = cut[good]
            measured.append(centre[good])
            noise.append(cov[good] + np.eye(2) * FIT_FLOOR ** 2)
        return np.concatenate([whole, cut]), np.concatenate(measured), np.concatenate(noise)

    def _fix(self, tracks: np.ndarray, measured: np.ndarray, noise: np.ndarray, stamp: float) -> None:
        """Correct the tracks by position measurements: the filter where a track has a velocity; a track's
        second sighting (at a later stamp) sets it from the displacement; one at the same stamp averages."""
        if not len(tracks):
            return
        going = self.velocity_updates[tracks] > 0
        t = tracks[going]
        models, covs, probs = self.models[t], self.model_covs[t], self.probs[t]
        tracking_kernels.imm_update(models, covs, probs, measured[going], np.ascontiguousarray(noise[going]))
        self.models[t], self.model_covs[t], self.probs[t] = models, covs, probs
        self.state[t], self.cov[t] = tracking_kernels.imm_combine(models, covs, probs)
        self.velocity_updates[t] += self.last_fix[t] < stamp
        dt = stamp - self.last_fix[tracks]
        second = tracks[~going & (dt > 0)]
        if len(second):
            state, cov = kalman.from_two_sightings(self.state[second, :2], self.cov[second, :2, :2],
                                                   measured[~going & (dt > 0)], noise[~going & (dt > 0)],
                                                   stamp - self.last_fix[second])
            self.state[second], self.cov[second] = state, cov
            self.models[second] = state[:, None, :]
            self.model_covs[second] = cov[:, None, :, :]
            self.probs[second] = kalman.INITIAL_PROBABILITY
            self.velocity_updates[second] = 1
        again = tracks[~going & (dt <= 0)]
        if len(again):
            prior, z = self.cov[again, :2, :2], measured[~going & (dt <= 0)]
            gain = prior @ np.linalg.inv(prior + noise[~going & (dt <= 0)])
            self.state[again, :2] += (gain @ (z - self.state[again, :2])[:, :, None])[:, :, 0]
            self.cov[again, :2, :2] = prior - gain @ prior
        self.last_fix[tracks] = stamp

    def _forget_missed(self, scans: list[Scan], stamp: float) -> None:
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
        fresh = (clusters.structure < STRUCTURE_SHARE) & ~clusters.unfit
        fresh[cluster_of[cluster_of >= 0]] = False
        if len(self.ids) and fresh.any():
            distance = np.hypot(*(clusters.centre[:, None, :] - self.state[None, :, :2]).transpose(2, 0, 1))
            fresh &= ~(distance < self.radius[None, :] + clusters.radius[:, None] + FRAGMENT_MARGIN).any(axis=1)
        new = clusters.select(fresh)
        n = len(new)
        if not n:
            return
        p = self.params
        state = np.column_stack([new.centre, np.zeros((n, 2))])
        cov = np.tile(np.diag([p.measurement_noise ** 2] * 2 + [p.initial_speed_sigma ** 2] * 2), (n, 1, 1))
        self._append(ids=np.arange(self._next_id, self._next_id + n), models=np.repeat(state[:, None], kalman.MODELS, 1),
                     model_covs=np.repeat(cov[:, None], kalman.MODELS, 1),
                     probs=np.tile(kalman.INITIAL_PROBABILITY, (n, 1)), state=state, cov=cov,
                     radius=np.maximum(new.radius, MIN_RADIUS), radius_known=~new.occluded, born=np.full(n, stamp),
                     origin=new.centre.copy(),
                     last_seen=np.full(n, stamp), last_fix=np.full(n, stamp), hits=np.ones(n, dtype=np.int64),
                     missed=np.zeros(n, dtype=np.int64), confirmed=np.full(n, p.confirm_hits <= 1),
                     moving=np.zeros(n, dtype=bool), since=np.full(n, np.nan),
                     velocity_updates=np.zeros(n, dtype=np.int64), on_structure=np.zeros(n, dtype=bool))
        self._next_id += n

    def _judge_motion(self, stamp: float) -> None:
        """The moving flag flips once the opposite condition has held for moving_hold: a speed above
        moving_speed by moving_confidence sigmas, measured by two displacements at least, off structure, to
        turn moving; below static_speed to stop. A track on structure stops at once."""
        p, (speed, sigma, stopped) = self.params, kalman.moving_speed_and_sigma(self.models, self.model_covs, self.probs)
        fast = self.confirmed & (self.velocity_updates >= 2) & ~self.on_structure & (stopped < STOPPED_BELOW) & \
            (speed - p.moving_confidence * sigma > p.moving_speed)
        opposite = np.where(self.moving, kalman.speed_and_sigma(self.state, self.cov)[0] < p.static_speed, fast)
        self.since = np.where(opposite, np.where(np.isnan(self.since), stamp, self.since), np.nan)
        flip = opposite & (stamp - self.since >= p.moving_hold)
        self.moving ^= flip
        self.since[flip] = np.nan
        self.moving &= ~self.on_structure

    def _keep(self, mask: np.ndarray) -> None:
        for name in _FIELDS:
            setattr(self, name, getattr(self, name)[mask])

    def _append(self, **rows) -> None:
        for name in _FIELDS:
            setattr(self, name, np.concatenate([getattr(self, name), rows[name]]))

    # -- results -----------------------------------------------------------------------------
    def tracks(self, include_tentative: bool = False) -> list[Track]:
        """Every confirmed track (and the tentative ones too, if asked) as of the last update."""
        return [Track(int(self.ids[i]), self.state[i, :2].copy(), self.state[i, 2:].copy(), self.cov[i].copy(),
                      float(self.radius[i]), float(self.stamp - self.born[i]), bool(self.confirmed[i]),
                      bool(self.moving[i]), float(self.stamp)) for i in np.flatnonzero(self.confirmed | include_tentative)]

    def moving_obstacles(self, now: float | None = None) -> np.ndarray:
        """Rows [x, y, vx, vy, radius] of the moving tracks, positions extrapolated to `now` (default: the last
        update's stamp)."""
        return self._rows_at(self.confirmed & self.moving, now)

    def _rows_at(self, rows: np.ndarray, now: float | None) -> np.ndarray:
        """[x, y, vx, vy, radius] of the `rows` tracks, positions extrapolated to `now`."""
        dt = 0.0 if now is None or self.stamp is None else float(now) - self.stamp
        state = self.state[rows]
        return np.column_stack([state[:, :2] + dt * state[:, 2:], state[:, 2:], self.radius[rows]])

    def moving_covariances(self, now: float | None = None) -> np.ndarray:
        """(K, 4, 4) covariances over x, y, vx, vy of the rows of moving_obstacles(now), in the same order,
        extrapolated as those are (constant velocity, the steady model's acceleration noise)."""
        moving = self.confirmed & self.moving
        dt = 0.0 if now is None or self.stamp is None else float(now) - self.stamp
        return kalman.extrapolate(self.state[moving], self.cov[moving], dt, self.params.acceleration_noise)[1]

    def moving_ids(self) -> np.ndarray:
        """The ids of the rows of moving_obstacles, in the same order."""
        return self.ids[self.confirmed & self.moving]

    def _clearing(self) -> np.ndarray:
        """The moving tracks whose marks are cleared: those that have left the place they were first seen by
        clearing_displacement (a static thing briefly taken for moving keeps its marks)."""
        moved = np.hypot(*(self.state[:, :2] - self.origin).T) >= self.params.clearing_displacement
        return self.confirmed & self.moving & moved

    def clearing_circles(self, now: float) -> np.ndarray:
        """(K, 3) circles x, y, r where clearing tracks were within clearing_time of `now`, plus where they are
        now, each radius widened by clearing_margin: the marks the costmaps should clear."""
        now_rows = self._rows_at(self._clearing(), now)[:, [0, 1, 4]]
        now_rows[:, 2] += self.params.clearing_margin
        return np.concatenate([self.trail.circles(now, self.params.clearing_margin), now_rows])


def _normalised_squared(offset: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """(M,) offset^T cov^-1 offset of (M, 2) offsets with (M, 2, 2) covariances."""
    return np.einsum("mi,mij,mj->m", offset, np.linalg.inv(cov), offset)


def _visible(scan: Scan, centres: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Whether a scan shows each object gone: within its field of view and range, the beam towards its centre
    passes the centre (not stopped by something nearer, by the object itself or by something touching it, nor
    lost)."""
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
    return inside & (reach[beam] >= distance)
