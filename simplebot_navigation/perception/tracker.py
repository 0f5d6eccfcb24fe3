"""ObstacleTracker: clusters of lidar returns followed over time by interacting multiple model filters
(docs/reference.md §6).

Per update (one scan, or the scans taken together): predict every track to the stamp, cut each scan into
clusters, assign clusters to tracks (Hungarian on centre distance, gated by each track's uncertainty), correct the
tracks, start a track at first sight from each unassigned cluster, delete tracks that visible scans keep missing,
and judge which tracks move. Clusters wider than max_obstacle_size are walls and never tracked. A track's second
sighting sets its velocity from the displacement; from then on a filter mixing a stopped, a steady and a
manoeuvring model follows it. A whole cluster measures the centre; a cut one (occluded) by a circle fitted to
the visible arc (measurement.py). A measurement too far from a track's prediction is another thing: the track
starts again there.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import linear_sum_assignment

from simplebot_navigation.perception import kalman, measurement, tracking_kernels
from simplebot_navigation.perception.measurement import MIN_RADIUS
from simplebot_navigation.perception.params import TrackerParams
from simplebot_navigation.perception.segmentation import Clusters, Scan, segment
from simplebot_navigation.perception.structure import StructureMap
from simplebot_navigation.perception.trail import ClearingTrail

#: how fast a track's radius follows its clusters' (exponential smoothing factor)
RADIUS_SMOOTHING = 0.3
#: a new cluster this close to an existing track's outline is a fragment of it, not a new track
FRAGMENT_MARGIN = 0.1
#: returns this far (m) beyond a moving track's predicted outline are still that obstacle's
ON_TRACK_M = 0.1
#: a cluster with this share of its returns on structure is structure
STRUCTURE_SHARE = 0.5
#: the association gate widens by this many sigmas of a track's position, up to MAX_GATE
GATE_SIGMAS, MAX_GATE = 2.0, 1.5
#: a measurement farther than JUMP_DISTANCE (metres) from a track's prediction or JUMP_GATE outside it
#: (normalised squared, chi-square 2 dof: 99.9 %), or beyond what max_obstacle_speed allows a track seen once by
#: JUMP_SIGMAS, is a jump to another thing: the track starts again there (no person strays 0.3 m from a steady
#: walk within a scan; a coasting track's covariance would let it take a tree that stands 1 m away)
JUMP_DISTANCE, JUMP_GATE, JUMP_SIGMAS = 0.3, 13.8, 3.0
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
                                      else np.full(2, np.nan), ~self._on_moving_tracks(points))
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

    def _on_moving_tracks(self, points: np.ndarray) -> np.ndarray:
        """(N,) whether each point lies on a moving track where it is predicted now (within its radius and
        ON_TRACK_M): such returns are that obstacle's, not evidence of structure. A big person walking along their
        own side keeps hitting the same cells for a second, as a wall does, and would stop their own track."""
        moving = np.flatnonzero(self.confirmed & self.moving)
        if not len(moving) or not len(points):
            return np.zeros(len(points), dtype=bool)
        dx = points[:, 0, None] - self.state[None, moving, 0]
        dy = points[:, 1, None] - self.state[None, moving, 1]
        with np.errstate(invalid="ignore"):           # rows of beams without a return are NaN: on nothing
            return (dx * dx + dy * dy <= (self.radius[moving] + ON_TRACK_M) ** 2).any(axis=1)

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
        seen = np.flatnonzero(cluster_of >= 0)
        matched = cluster_of[seen]
        self.last_seen[seen] = stamp
        self.on_structure[seen] = (clusters.structure[matched] >= STRUCTURE_SHARE) | clusters.unfit[matched]
        self.hits[seen] += 1
        self.missed[seen] = 0
        whole = ~clusters.occluded[matched]
        # A cut outline shows only part of the obstacle: it may make a track larger, never smaller.
        observed = np.maximum(clusters.radius[matched], MIN_RADIUS)
        observed = np.where(whole, observed, np.maximum(observed, self.radius[seen]))
        self.radius[seen] += RADIUS_SMOOTHING * (observed - self.radius[seen])
        self.radius_known[seen[whole]] = True
        m = measurement.centres(clusters, matched, points, self.state[seen, :2], self._position_covs(seen),
                                self.radius[seen], self.radius_known[seen], self.params)
        self.radius[seen[m.learnt]], self.radius_known[seen[m.learnt]] = m.learnt_radius, True
        self._fix(seen[m.tracks], m.centre, m.noise, stamp)
        self.confirmed |= self.hits >= self.params.confirm_hits

    def _fix(self, tracks: np.ndarray, measured: np.ndarray, noise: np.ndarray, stamp: float) -> None:
        """Correct the tracks by position measurements: the filter where a track has a velocity; a track's
        second sighting (at a later stamp) sets it from the displacement; one at the same stamp averages. A
        measurement the track's obstacle cannot have made (_jumps) starts the track again there instead."""
        jumped = self._jumps(tracks, measured, noise, stamp)
        if jumped.any():
            self._restart(tracks[jumped], measured[jumped], noise[jumped], stamp)
            tracks, measured, noise = tracks[~jumped], measured[~jumped], noise[~jumped]
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

    def _jumps(self, tracks: np.ndarray, measured: np.ndarray, noise: np.ndarray, stamp: float) -> np.ndarray:
        """Measurements the track's obstacle cannot have made: the segmentation or the association took another
        thing for it, and a velocity from the displacement would be false."""
        offset, cov = measured - self.state[tracks, :2], self.cov[tracks, :2, :2] + noise
        known, distance = self.velocity_updates[tracks] > 0, np.hypot(*offset.T)
        reach = self.params.max_obstacle_speed * (stamp - self.last_fix[tracks]) + \
            JUMP_SIGMAS * np.sqrt(np.trace(cov, axis1=1, axis2=2))
        return np.where(known, (distance > JUMP_DISTANCE) | (measurement.normalised_squared(offset, cov) > JUMP_GATE),
                        distance > reach)

    def _restart(self, tracks: np.ndarray, measured: np.ndarray, noise: np.ndarray, stamp: float) -> None:
        """The tracks start again at the measurements, their velocities measured anew from the next sighting
        (until then kept, as are their ids and moving flags: a person lost among others and found again stays
        moving; a false track turns static once its new velocity says so)."""
        state, cov = self._first_sight(measured, noise)
        state[:, 2:] = self.state[tracks, 2:]
        self.state[tracks], self.cov[tracks] = state, cov
        self.models[tracks], self.model_covs[tracks] = state[:, None], cov[:, None]
        self.origin[tracks], self.last_fix[tracks], self.velocity_updates[tracks] = measured, stamp, 0

    def _first_sight(self, centres: np.ndarray, noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """States and covariances of obstacles seen once: standing, with an uncertain velocity."""
        cov = np.zeros((len(centres), 4, 4))
        cov[:, :2, :2] = noise
        cov[:, 2, 2] = cov[:, 3, 3] = self.params.initial_speed_sigma ** 2
        return np.column_stack([centres, np.zeros((len(centres), 2))]), cov

    def _forget_missed(self, scans: list[Scan], stamp: float) -> None:
        """A track no scan matched counts a miss if some scan should have seen it; too many misses, a tentative
        track's first miss, or too long unseen delete it."""
        unmatched = np.flatnonzero(self.last_seen < stamp)
        if len(unmatched):
            visible = np.zeros(len(unmatched), dtype=bool)
            for scan in scans:
                visible |= scan.shows_gone(self.state[unmatched, :2], self.radius[unmatched])
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
        state, cov = self._first_sight(new.centre, np.tile(np.eye(2) * p.measurement_noise ** 2, (n, 1, 1)))
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
