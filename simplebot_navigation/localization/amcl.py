"""Amcl: ROS 1 amcl's localization as a pure object (docs/reference.md §8). No ROS here: the node hands in the map,
odometry poses and scans as plain values and takes the estimate and the particles back.

One cycle, as amcl's laserReceived runs it for every scan:

1. ``odometry_update(odom_pose)`` with the odometry pose (x, y, yaw in the odom frame) at the scans' time. The
   first pose after construction, an initial pose or global localization is only remembered. Afterwards the
   particles move by the motion since the last filter update once it exceeds update_min_d along x or along y
   (each on its own, as amcl compares them) or update_min_a in yaw, or when an update is forced
   (``request_nomotion_update``); while an update is due every further odometry pose moves them too.
2. ``sensor_update(scans, source)`` weighs the particles with each scan of one laser in turn, once per laser after
   each motion update (amcl's per-laser update flags: the front and the back lidar both count); every scan counts
   towards resample_interval (amcl counts each laser's message), and resampling happens when the count reaches it.
3. ``estimate()``: the heaviest cluster's mean with amcl's covariance; amcl publishes it after each resampling.

Global relocalization (relocalization.py, ours): ``global_localization()`` spreads the particles uniformly, as amcl,
and once the next scans are in (every laser's, or one laser's second) puts them round the scan matcher's best poses
over the whole map; recovery's injected particles come from those candidates too, matched anew at most every
recovery_match_interval of the scans' stamps. global_localization_candidates 0 keeps amcl's uniform spreading.

``reset()`` (time went backwards) starts over as if constructed anew: particles around initial_pose_* (which the
node may have updated from the last estimate, save_pose_rate) and the generator re-seeded.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from simplebot_navigation.localization import clusters
from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.localization.laser_models import LaserModel, RangeScan
from simplebot_navigation.localization.map_grid import AmclMap
from simplebot_navigation.localization.motion_model import angle_diff, sample_motion
from simplebot_navigation.localization.particle_filter import ParticleFilter
from simplebot_navigation.localization.relocalization import Relocalizer
from simplebot_navigation.parameters import fields_of

#: the narrowest spread a filter restarted on a new map keeps (m^2 and rad^2: 1 cm, 0.6 deg)
MIN_RESTART_VARIANCE = 1e-4


class Amcl:
    """Adaptive Monte Carlo localization on one occupancy grid.

    ``map_data``: int8 [height, width] in nav_msgs/OccupancyGrid order (row 0 at the origin's y; -1 unknown,
    0..100), ``resolution`` in m per cell, ``origin`` = (x, y, yaw) of the grid's corner in the global frame."""

    def __init__(self, params: AmclParams, map_data, resolution: float, origin=(0.0, 0.0, 0.0)):
        params.check()
        self.params = params
        self.map = AmclMap(map_data, resolution, origin)
        self.laser = LaserModel(params, self.map)
        self.relocalizer = Relocalizer(self.map, map_data)
        self.reset()

    def reset(self) -> None:
        """Forget everything: particles around the initial_pose_* parameters, a fresh generator from ``seed``."""
        p = self.params
        self.filter = ParticleFilter(p, self.map, np.random.default_rng(p.seed))
        self.filter.injector = self._recovery_poses
        self.relocalizer.forget()
        self._odom_reference: np.ndarray | None = None
        self._odom_latest = np.zeros(3)                 # the last odometry pose given, moved or not
        self._stamp: float | None = None                # the last scans' stamp, if the caller gives stamps
        self._update_due = True
        self._sources_used: set[str] = set()     # the lasers weighed since the particles last moved
        self._force_update = False
        self._resample_count = 0
        self.filter.init_gaussian((p.initial_pose_x, p.initial_pose_y, p.initial_pose_a),
                                  np.diag([p.initial_cov_xx, p.initial_cov_yy, p.initial_cov_aa]))

    def set_initial_pose(self, x: float, y: float, yaw: float, covariance) -> None:
        """Restart the particles around (x, y, yaw) in the global frame with a 3x3 (x, y, yaw) covariance
        (amcl's /initialpose). ValueError naming the field if a value is not finite or the covariance not
        positive definite; the filter then stays as it was."""
        for name, value in (("x", x), ("y", y), ("yaw", yaw)):
            if not math.isfinite(value):
                raise ValueError(f"initial pose {name}: must be finite, got {value!r}")
        cov = np.asarray(covariance, dtype=float)
        if cov.shape != (3, 3):
            raise ValueError(f"initial pose covariance: expected 3x3 (x, y, yaw), got shape {cov.shape}")
        if not np.all(np.isfinite(cov)):
            raise ValueError("initial pose covariance: must be finite")
        if not np.allclose(cov, cov.T, rtol=1e-9, atol=1e-12):
            raise ValueError("initial pose covariance: must be symmetric")
        try:
            np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            raise ValueError(f"initial pose covariance: must be positive definite, eigenvalues "
                             f"{np.round(np.linalg.eigvalsh(cov), 6).tolist()}") from None
        self.filter.init_gaussian((x, y, yaw), cov)
        self._restarted()
        self.relocalizer.pending = False        # a pose given wins over a global localization still to seed
        if self.params.force_update_after_initialpose:
            self._force_update = True

    def global_localization(self) -> None:
        """Spread max_particles particles uniformly over the free cells (amcl's global_localization service); unless
        global_localization_candidates is 0, the next scans then seed them round the matcher's candidates."""
        self.filter.init_uniform()
        self._restarted()
        if self.params.global_localization_candidates > 0:
            self.relocalizer.request()

    def request_nomotion_update(self) -> None:
        """Make the next odometry update move the particles and the next sensor update weigh them, whether the
        robot moved or not (amcl's request_nomotion_update service)."""
        self._force_update = True

    def _restarted(self) -> None:
        self._odom_reference = None
        self._update_due = True
        self._sources_used = set()

    def odometry_update(self, odom_pose) -> bool:
        """Take the odometry pose (x, y, yaw) at the next scans' time; True if the particles moved and a sensor
        update is due. ValueError if a value is not finite."""
        pose = np.array(odom_pose, dtype=float)           # a copy: the caller may reuse its array
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ValueError(f"odometry pose: expected finite (x, y, yaw), got {odom_pose!r}")
        self._odom_latest = pose
        if self._odom_reference is None:
            self._odom_reference = pose
            self._update_due = True
            self._sources_used = set()
            self._resample_count = 0
            return False
        reference = self._odom_reference
        delta = np.array([pose[0] - reference[0], pose[1] - reference[1], float(angle_diff(pose[2], reference[2]))])
        p = self.params
        move = (self._update_due or self._force_update or abs(delta[0]) > p.update_min_d
                or abs(delta[1]) > p.update_min_d or abs(delta[2]) > p.update_min_a)
        self._force_update = False
        if not move:
            return False
        alphas = (p.odom_alpha1, p.odom_alpha2, p.odom_alpha3, p.odom_alpha4)
        self.filter.poses = sample_motion(self.filter.poses, delta, reference[2], alphas, p.motion_model,
                                          self.filter.rng)
        self._odom_reference = pose
        self._update_due = True
        self._sources_used = set()
        return True

    def sensor_update(self, scans: list[RangeScan], source: str = "", stamp: float | None = None) -> bool:
        """Weigh the particles with the scans of one ``source`` (a laser), and resample every resample_interval
        scans: once per source after each motion update, as amcl updates each of its lasers once (lidars are
        seldom in step, so each one's next scan counts). True if the scans were used. ValueError naming the field
        of a malformed scan or a non-finite ``stamp`` (nothing changes then).

        Every call's scans are kept for the matcher, used or not; a global localization due to be seeded is seeded
        first (and these scans then weigh the seeded particles). ``stamp`` (s, the scans' time) bounds how often
        recovery matches; without stamps recovery injects uniform particles, as amcl."""
        for scan in scans:
            scan.check()
        if stamp is not None and not math.isfinite(stamp):
            raise ValueError(f"stamp: must be finite, got {stamp!r}")
        self._stamp = stamp
        if self.relocalizer.observe(source, scans, self._odom_latest) and self._seed():
            self._sources_used = set()
        if source in self._sources_used:
            return False
        grid_poses = self.map.to_grid(self.filter.poses)
        for scan in scans:
            factors = self.laser.weights(grid_poses, scan, self.filter.converged)
            if factors is None:
                continue
            self.filter.apply_weights(factors)
            self._resample_count += 1
            if self._resample_count % self.params.resample_interval == 0:
                self.filter.resample()
                grid_poses = self.map.to_grid(self.filter.poses)
        self._update_due = False
        self._sources_used.add(source)
        return True

    def _particle_odom(self) -> np.ndarray:
        """The odometry pose the particles stand for (the last one they moved to, else the last given)."""
        return self._odom_reference if self._odom_reference is not None else self._odom_latest

    def _seed(self) -> bool:
        """Global localization's particles round the matcher's candidates; False (uniform ones stay, and the
        seeding waits for the next scans) when the kept scans give none."""
        p, odom = self.params, self._particle_odom()
        if not self.relocalizer.match(odom, self._stamp, p):
            return False
        self.filter.restart(self.relocalizer.poses(p.max_particles, p, odom, self.filter.rng,
                                                   self.filter.random_poses))
        self.relocalizer.pending = False
        return True

    def _recovery_poses(self, n: int) -> np.ndarray:
        return self.relocalizer.recovery_poses(n, self.params, self._particle_odom(), self._stamp, self.filter.rng,
                                               self.filter.random_poses)

    def reconfigure(self, params: AmclParams) -> None:
        """New parameters while running (a live change), the particles kept; a change of max_particles takes
        effect at the next resampling."""
        params.check()
        laser_changed = any(getattr(params, f.name) != getattr(self.params, f.name)
                            for f in dataclasses.fields(params) if f.name.startswith(("laser_", "do_beamskip", "beam_"))
                            )
        self.params = params
        if laser_changed:      # the likelihood field is the model's costly part: kept unless the laser changed
            self.laser = LaserModel(params, self.map)
        self.filter.params = params

    def on_new_map(self, map_data, resolution: float, origin=(0.0, 0.0, 0.0)) -> tuple[Amcl, bool]:
        """The filter for a new map, starting round this one's estimate with its spread (each variance within
        initial_cov_*'s bounds, at least MIN_RESTART_VARIANCE), and whether the estimate lies in the new map's free
        space (if not, the new filter's particles start round a pose the new map has no room for). ValueError for
        a map the filter cannot take; this filter stays as it was."""
        last = self.estimate()
        specs = fields_of(AmclParams)
        variances = {name: float(np.clip(last.covariance[i, i], MIN_RESTART_VARIANCE, specs[name].high))
                     for i, name in enumerate(("initial_cov_xx", "initial_cov_yy", "initial_cov_aa"))}
        params = dataclasses.replace(self.params, initial_pose_x=last.x, initial_pose_y=last.y,
                                     initial_pose_a=last.yaw, **variances)
        new = Amcl(params, map_data, resolution, origin)
        return new, new.map.is_free(last.x, last.y)

    def estimate(self) -> clusters.PoseEstimate:
        """The heaviest cluster's mean with the whole filter's covariance, as amcl publishes on amcl_pose."""
        return clusters.estimate(self.filter.poses, self.filter.weights)

    @property
    def particles(self) -> np.ndarray:
        """(N, 3) x, y, yaw of the particles in the global frame (amcl's particlecloud); a copy."""
        return self.filter.poses.copy()

    @property
    def weights(self) -> np.ndarray:
        """The particles' normalised weights; a copy."""
        return self.filter.weights.copy()
