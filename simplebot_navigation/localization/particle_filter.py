"""amcl's particle filter (pf.c): the particles, their weights, KLD-sampling resampling and recovery.

- Weighting: each particle's weight is multiplied by its sensor factor and the weights normalised; the mean of the
  multiplied weights feeds a slow and a fast running average (recovery_alpha_slow, recovery_alpha_fast; Augmented
  MCL, Probabilistic Robotics p. 258). If every factor is zero the weights become uniform.
- Resampling draws particles in proportion to their weight (amcl's plain multinomial draw, not the low-variance
  sampler), each one instead a random pose on a free cell with probability max(0, 1 - w_fast / w_slow), and stops
  as soon as the particles drawn exceed the KLD bound for the number of 0.5 m x 0.5 m x 10 deg bins they fill
  (kld_err, kld_z, within min_particles and max_particles). The injected poses come from ``injector``: uniform
  free cells, or what Amcl sets (the scan matcher's candidates). After an injection both averages restart. With
  selective_resampling the particles are kept as they are while the effective sample size 1 / sum(w^2) is above
  half their number.
- Convergence (for beam skipping): every particle within 0.5 m of the unweighted mean in x and in y.

All randomness comes from one numpy Generator, so the same seed and inputs give the same particles.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from simplebot_navigation.localization import amcl_kernels as kernels
from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.localization.clusters import BIN_XY, BIN_YAW, YAW_BINS
from simplebot_navigation.localization.map_grid import AmclMap
from simplebot_navigation.localization.motion_model import wrap

#: pf.c's dist_threshold: the filter has converged when all particles lie this close to their mean (x and y)
CONVERGED_SPREAD = 0.5


class ParticleFilter:
    """Particles (N, 3) x, y, yaw in the map frame, yaw in [-pi, pi), and their normalised weights."""

    def __init__(self, params: AmclParams, amap: AmclMap, rng: np.random.Generator):
        self.params = params
        self.map = amap
        self.rng = rng
        self._free_rows, self._free_cols = amap.free_cells()
        self.poses = np.zeros((params.max_particles, 3))
        self.weights = np.full(params.max_particles, 1.0 / params.max_particles)
        self.w_slow = self.w_fast = 0.0
        self.n_effective = float(params.max_particles)
        self.converged = False
        #: n poses for recovery's injection (amcl's uniformPoseGenerator unless Amcl sets its matcher's)
        self.injector: Callable[[int], np.ndarray] = self.random_poses

    def init_gaussian(self, mean, covariance: np.ndarray) -> None:
        """max_particles particles drawn from N(mean, covariance) (amcl's pf_init)."""
        n = self.params.max_particles
        draws = self.rng.standard_normal((n, 3)) @ np.linalg.cholesky(covariance).T + np.asarray(mean)
        draws[:, 2] = wrap(draws[:, 2])
        self.restart(draws)

    def init_uniform(self) -> None:
        """max_particles particles on random free cells with random yaw (global localization)."""
        self.restart(self.random_poses(self.params.max_particles))

    def random_poses(self, n: int) -> np.ndarray:
        """n poses at the centres of uniformly drawn free cells, yaw uniform in [-pi, pi) (amcl's
        uniformPoseGenerator)."""
        pick = self.rng.integers(0, len(self._free_rows), n)
        out = np.empty((n, 3))
        out[:, :2] = self.map.cell_centres(self._free_rows[pick], self._free_cols[pick])
        out[:, 2] = self.rng.uniform(-math.pi, math.pi, n)
        return out

    def restart(self, poses: np.ndarray) -> None:
        """These particles, equally weighted, and the recovery averages started over."""
        self.poses = poses
        self.weights = np.full(len(poses), 1.0 / len(poses))
        self.w_slow = self.w_fast = 0.0
        self.n_effective = float(len(poses))
        self.converged = False

    def apply_weights(self, factors: np.ndarray) -> None:
        """Multiply the weights by one scan's factors, normalise, and update the recovery averages (pf.c's
        pf_update_sensor)."""
        weights = self.weights * factors
        total = weights.sum()
        if not total > 0.0:
            self.weights = np.full(len(weights), 1.0 / len(weights))
            self.n_effective = math.inf     # amcl's 1 / 0
            return
        w_avg = total / len(weights)
        self.weights = weights / total
        self.n_effective = 1.0 / float(self.weights @ self.weights)
        self.w_slow = w_avg if self.w_slow == 0.0 else self.w_slow + self.params.recovery_alpha_slow * (
            w_avg - self.w_slow)
        self.w_fast = w_avg if self.w_fast == 0.0 else self.w_fast + self.params.recovery_alpha_fast * (
            w_avg - self.w_fast)

    def injection_probability(self) -> float:
        """max(0, 1 - w_fast / w_slow): the share of resampled particles that are random (0 before any weights)."""
        if self.w_slow <= 0.0:
            return 0.0
        return max(0.0, 1.0 - self.w_fast / self.w_slow)

    def resample(self) -> None:
        """KLD-sampling resampling with random injection (pf.c's pf_update_resample)."""
        p = self.params
        if p.selective_resampling and self.n_effective > 0.5 * len(self.poses):
            return
        max_n = p.max_particles
        w_diff = self.injection_probability()
        cumulative = np.concatenate(([0.0], np.cumsum(self.weights)))
        u_pick, u_inject = self.rng.random(max_n), self.rng.random(max_n)
        random_poses = self.injector(max_n) if w_diff > 0.0 else np.zeros((0, 3))
        out = np.empty((max_n, 3))
        count = kernels.kld_resample(self.poses, cumulative, u_pick, u_inject, random_poses, w_diff, BIN_XY,
                                     BIN_YAW, YAW_BINS, p.min_particles, max_n, p.kld_err, p.kld_z, out)
        self.poses = out[:count].copy()
        self.weights = np.full(count, 1.0 / count)
        self.n_effective = float(count)
        if w_diff > 0.0:
            self.w_slow = self.w_fast = 0.0
        self.converged = bool(np.all(np.abs(self.poses[:, :2] - self.poses[:, :2].mean(axis=0))
                                     <= CONVERGED_SPREAD))
