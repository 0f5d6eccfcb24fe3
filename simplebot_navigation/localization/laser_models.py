"""amcl's laser models: which beams of a scan count, how their ranges are read, and the per-particle weight factor.

A scan is used as amcl's laserReceived prepares it: the range limits are the scan's, narrowed by laser_min_range /
laser_max_range when those are positive; a range at or below the lower limit becomes a max-range reading (amcl has
no notion of a minimum range), one beyond the upper limit (+inf included) is no reading at all; beams are taken at
an even step through the scan (amcl's step differs per model, see ``beam_indices``). NaN readings are skipped by
every model (amcl's beam model would turn the particle's weight into NaN).

- likelihood_field: 1 + the sum over beams of pz^3, pz = z_hit exp(-d^2 / 2 sigma_hit^2) + z_rand / range_max with
  d the distance from the beam's end to the nearest occupied cell (capped at laser_likelihood_max_dist, also
  beyond the map); max-range readings are skipped.
- likelihood_field_prob: the product of the same pz, optionally with beam skipping.
- beam: 1 + the sum of pz^3 of the book's mixture (hit, short, max, rand) around the range ray-cast in the map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simplebot_navigation.localization import amcl_kernels as kernels
from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.localization.map_grid import AmclMap


@dataclass(frozen=True)
class RangeScan:
    """One planar laser scan as the filter takes it (a sensor_msgs/LaserScan's numbers and its sensor's pose).

    ``sensor_pose`` is (x, y, yaw) of the scan's frame in the robot's base frame; beam i points at
    ``angle_min + i * angle_increment`` in that frame."""
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    sensor_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def check(self) -> None:
        """ValueError naming the first field that cannot be used."""
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"scan {name}: must be finite, got {getattr(self, name)!r}")
        if self.range_max <= 0.0 or self.range_min < 0.0:
            raise ValueError(f"scan range_min / range_max: need 0 <= range_min and 0 < range_max, got "
                             f"{self.range_min!r} / {self.range_max!r}")
        if len(self.sensor_pose) != 3 or not all(math.isfinite(v) for v in self.sensor_pose):
            raise ValueError(f"scan sensor_pose: expected finite (x, y, yaw), got {self.sensor_pose!r}")
        if np.ndim(self.ranges) != 1:
            raise ValueError(f"scan ranges: expected one range per beam, got shape {np.shape(self.ranges)}")


def beam_indices(count: int, max_beams: int, model: str) -> np.ndarray:
    """The beams amcl uses of a scan of ``count``: every step-th from the first, step (count - 1) // (max_beams - 1)
    for beam and likelihood_field, ceil(count / max_beams) for likelihood_field_prob (at least 1)."""
    if model == "likelihood_field_prob":
        step = math.ceil(count / max_beams)
    else:
        step = (count - 1) // (max_beams - 1)
    return np.arange(0, count, max(step, 1))


def range_limits(scan: RangeScan, params: AmclParams) -> tuple[float, float]:
    """(range_min, range_max) used for a scan."""
    range_max = min(scan.range_max, params.laser_max_range) if params.laser_max_range > 0 else scan.range_max
    range_min = max(scan.range_min, params.laser_min_range) if params.laser_min_range > 0 else scan.range_min
    return range_min, range_max


def read_beams(scan: RangeScan, params: AmclParams) -> tuple[np.ndarray, np.ndarray, float]:
    """(bearings, ranges, range_max) of the beams a model weighs: sub-sampled, short readings turned into
    max-range ones, NaN and beyond-range readings dropped."""
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    chosen = beam_indices(len(ranges), params.laser_max_beams, params.laser_model_type)
    range_min, range_max = range_limits(scan, params)
    r = ranges[chosen]
    r = np.where(r <= range_min, range_max, r)
    keep = r <= range_max            # False for NaN and for anything beyond range_max
    return scan.angle_min + chosen[keep] * scan.angle_increment, r[keep], range_max


class LaserModel:
    """Weighs particles against scans with the configured model; the map's fields are computed once."""

    def __init__(self, params: AmclParams, amap: AmclMap):
        self.params = params
        self.map = amap
        self.model = params.laser_model_type
        if self.model == "beam":
            self._blocked = amap.blocked()
            self._clearance = amap.clearance()
        else:
            distance = amap.obstacle_distance(params.laser_likelihood_max_dist)
            self._gauss = params.laser_z_hit * np.exp(-distance ** 2 / (2 * params.laser_sigma_hit ** 2))
            max_dist = params.laser_likelihood_max_dist
            self._gauss_off_map = params.laser_z_hit * math.exp(-max_dist ** 2 / (2 * params.laser_sigma_hit ** 2))
            self._near = distance < params.beam_skip_distance
        self._pz_tables: dict[float, tuple[np.ndarray, float]] = {}

    def weights(self, grid_poses: np.ndarray, scan: RangeScan, converged: bool = False) -> np.ndarray | None:
        """Each particle's weight factor for one scan (poses from AmclMap.to_grid), or None when amcl would not
        use the scan (laser_max_beams below 2)."""
        scan.check()
        if self.params.laser_max_beams < 2:
            return None
        bearings, ranges, range_max = read_beams(scan, self.params)
        out = np.empty(len(grid_poses))
        sx, sy, syaw = scan.sensor_pose
        if self.model == "beam":
            p = self.params
            z = np.array([p.laser_z_hit, p.laser_z_short, p.laser_z_max, p.laser_z_rand, p.laser_sigma_hit,
                          p.laser_lambda_short])
            sensor = np.array([sx / self.map.resolution, sy / self.map.resolution, syaw])
            kernels.beam_model_weights(grid_poses, sensor, bearings, ranges, range_max, self.map.resolution,
                                       self._blocked, self._clearance, z, out)
            return out
        hits = ranges < range_max                       # the likelihood field models skip max-range readings
        angles = syaw + bearings[hits]
        ends = np.column_stack((sx + ranges[hits] * np.cos(angles), sy + ranges[hits] * np.sin(angles)))
        ends /= self.map.resolution
        table, off_map = self.pz_table(range_max)
        if self.model == "likelihood_field":
            kernels.likelihood_field_weights(grid_poses, ends, table, off_map, out)
        else:
            p = self.params
            kernels.likelihood_field_prob_weights(grid_poses, ends, table, off_map, self._near,
                                                  p.do_beamskip and converged, p.laser_max_beams,
                                                  p.beam_skip_threshold, p.beam_skip_error_threshold, out)
        return out

    def pz_table(self, range_max: float) -> tuple[np.ndarray, float]:
        """pz of a beam ending in each cell, and beyond the map, for scans of this range_max (ln pz for
        likelihood_field_prob, which multiplies them)."""
        if range_max not in self._pz_tables:
            if len(self._pz_tables) >= 4:       # lasers of a few kinds, not a new table per scan
                self._pz_tables.clear()
            rand = self.params.laser_z_rand / range_max
            table, off_map = self._gauss + rand, np.float64(self._gauss_off_map + rand)
            if self.model == "likelihood_field_prob":
                with np.errstate(divide="ignore"):
                    table, off_map = np.log(table), np.log(off_map)
            self._pz_tables[range_max] = table, float(off_map)
        return self._pz_tables[range_max]
