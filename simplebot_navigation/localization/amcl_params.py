"""amcl's parameters (ROS 1 ``/amcl/*``; docs/reference.md §8).

Defaults are what ROS 1 noetic's amcl node reads when a parameter is not set (its ``param()`` fallbacks), which
for ``recovery_alpha_slow`` / ``recovery_alpha_fast`` differ from the wiki and AMCL.cfg (0.0, disabled): the node
falls back to 0.001 and 0.1 and ignores dynamic_reconfigure's first call. Lower bounds are what the algorithm
needs (ROS 1 divides by ``kld_err`` and takes ``resample_interval`` as a modulus); the cfg's upper bounds are
slider ranges for rqt and are not enforced (the robot's scans have 683 beams, the cfg stops at 100).

Parameters the pure filter does not use (frames, transform_tolerance, tf_broadcast, first_map_only,
save_pose_rate) are the ROS node's (ros/amcl/amcl_node.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from simplebot_navigation.parameters import ParameterError, build, fields_of, param
from simplebot_navigation.slam.scan_matcher import MAX_CANDIDATES

LASER_MODELS = ("likelihood_field", "beam", "likelihood_field_prob")
ODOM_MODELS = ("diff", "diff-corrected", "omni", "omni-corrected")
#: the differential-drive model used when an omnidirectional one is configured
DIFF_FOR_OMNI = {"omni": "diff", "omni-corrected": "diff-corrected"}

#: ours: the most particles a configuration may ask for (each costs memory and time at every update)
MAX_PARTICLES = 1_000_000
#: ours: physical bounds of the other numbers (docs/reference.md §8.6): a value beyond them is a mistake, and some
#: (a post-dating of 1e308 s, a likelihood field 1e6 m deep) would break what uses them
MAX_DISTANCE = 1000.0           # m: ranges, travel, spreads
MAX_COORDINATE = 1e6            # m: a pose in the global frame
MAX_TRANSFORM_TOLERANCE = 10.0  # s: tf2's default cache holds 10 s; a later stamp is a transform that never expires
MAX_RATE = 100.0                # Hz
MAX_BEAMS = 100_000             # readings of one scan
MAX_LIKELIHOOD_DIST = 100.0     # m: capped distances to the nearest obstacle
MAX_ALPHA = 100.0               # odometry noise factors (the cfg's sliders stop at 10)
MAX_RECOVERY_MATCH_INTERVAL = 3600.0  # s: an hour; a longer wait is as good as never matching
_NODE = "amcl's ROS node offers no diagnostics and no set_map service"
_UNUSED_IN_ROS1 = "ROS 1's amcl reads it but never uses it either"
_OMNI = "odom_alpha5 is the strafe noise of the omni models; a differential drive does not strafe"


@dataclass
class AmclParams:
    # Overall filter
    min_particles: int = param(100, "", "fewest particles KLD sampling keeps", ge=1, le=MAX_PARTICLES, rounds=True)
    max_particles: int = param(5000, "", "most particles; global localization spreads this many", ge=1,
                               le=MAX_PARTICLES, rounds=True)
    kld_err: float = param(0.01, "", "KLD sampling: largest error between the true and the sampled distribution",
                           gt=0.0, le=1.0)
    kld_z: float = param(0.99, "", "KLD sampling: the upper standard normal quantile z itself (amcl uses the "
                         "value as z, so 0.99 is z = 0.99)", ge=0.0, le=10.0)
    update_min_d: float = param(0.2, "m", "odometry travel along x or y (each on its own) before a filter update",
                                ge=0.0, le=MAX_DISTANCE)
    update_min_a: float = param(math.pi / 6, "rad", "odometry rotation before a filter update", ge=0.0,
                                le=2 * math.pi)
    resample_interval: int = param(2, "", "scans (one per laser) weighed between resamplings", ge=1,
                                  le=1000, rounds=True)
    transform_tolerance: float = param(0.1, "s", "how far the published map -> odom transform is post-dated",
                                       ge=0.0, le=MAX_TRANSFORM_TOLERANCE)
    recovery_alpha_slow: float = param(0.001, "", "decay rate of the long-term average likelihood; 0 disables "
                                       "recovery", ge=0.0, le=1.0)
    recovery_alpha_fast: float = param(0.1, "", "decay rate of the short-term average likelihood; random "
                                       "particles are injected while it is below the long-term one", ge=0.0,
                                       le=1.0)
    selective_resampling: bool = param(False, "", "resample only when the effective sample size falls below "
                                       "half the particles")
    initial_pose_x: float = param(0.0, "m", "initial pose mean, x in the global frame", ge=-MAX_COORDINATE,
                                  le=MAX_COORDINATE)
    initial_pose_y: float = param(0.0, "m", "initial pose mean, y in the global frame", ge=-MAX_COORDINATE,
                                  le=MAX_COORDINATE)
    initial_pose_a: float = param(0.0, "rad", "initial pose mean, yaw in the global frame", ge=-2 * math.pi,
                                  le=2 * math.pi)
    initial_cov_xx: float = param(0.5 * 0.5, "m^2", "initial pose variance of x", gt=0.0,
                                  le=MAX_COORDINATE ** 2)
    initial_cov_yy: float = param(0.5 * 0.5, "m^2", "initial pose variance of y", gt=0.0,
                                  le=MAX_COORDINATE ** 2)
    initial_cov_aa: float = param((math.pi / 12) ** 2, "rad^2", "initial pose variance of yaw", gt=0.0,
                                  le=(2 * math.pi) ** 2)
    force_update_after_initialpose: bool = param(False, "", "force a filter update (no motion needed) after a "
                                                 "new initial pose")
    force_update_after_set_map: bool = param(False, "", "force a filter update after the set_map service",
                                             not_implemented=_NODE)
    gui_publish_rate: float = param(-1.0, "Hz", "largest rate of visualisation output, -1 for none", ge=-1.0,
                                    le=MAX_RATE,
                                    not_implemented=_UNUSED_IN_ROS1)
    save_pose_rate: float = param(0.5, "Hz", "rate at which the estimate is stored in initial_pose_* and "
                                  "initial_cov_*, -1 for never", ge=-1.0, le=MAX_RATE)
    use_map_topic: bool = param(False, "", "subscribe to the map topic instead of calling static_map",
                                not_implemented="the map always comes from the latched map topic, as with "
                                "use_map_topic: true; ROS 1's static_map service is not called", restart=True)
    first_map_only: bool = param(False, "", "use only the first map received")
    tf_broadcast: bool = param(True, "", "publish map -> odom on /tf")
    std_warn_level_x: float = param(0.2, "m", "diagnostics warn above this standard deviation of x", ge=0.0,
                                    le=MAX_DISTANCE,
                                    not_implemented=_NODE)
    std_warn_level_y: float = param(0.2, "m", "diagnostics warn above this standard deviation of y", ge=0.0,
                                    le=MAX_DISTANCE,
                                    not_implemented=_NODE)
    std_warn_level_yaw: float = param(0.1, "rad", "diagnostics warn above this standard deviation of yaw",
                                      ge=0.0, le=math.pi, not_implemented=_NODE)
    bag_scan_period: float = param(-1.0, "s", "pause between scans when amcl replays a bag itself", ge=-1.0,
                                   le=60.0,
                                   not_implemented="amcl's own bag replay (--run-from-bag) is not offered; "
                                   "replay the bag with ros2 bag instead")
    # Laser model
    laser_min_range: float = param(-1.0, "m", "shortest range used; 0 or less (-1) takes the scan's "
                                   "range_min", ge=-1.0, le=MAX_DISTANCE)
    laser_max_range: float = param(-1.0, "m", "longest range used; 0 or less (-1) takes the scan's "
                                   "range_max", ge=-1.0, le=MAX_DISTANCE)
    laser_max_beams: int = param(30, "", "evenly spaced beams used of each scan (fewer than 2: scans are not "
                                 "used, as in amcl)", ge=0, le=MAX_BEAMS, rounds=True)
    laser_z_hit: float = param(0.95, "", "mixture weight of the hit (Gaussian) part", ge=0.0, le=1.0)
    laser_z_short: float = param(0.1, "", "mixture weight of the short (exponential) part, beam model", ge=0.0,
                                 le=1.0)
    laser_z_max: float = param(0.05, "", "mixture weight of the max-range part, beam model", ge=0.0, le=1.0)
    laser_z_rand: float = param(0.05, "", "mixture weight of the uniform part", ge=0.0, le=1.0)
    laser_sigma_hit: float = param(0.2, "m", "standard deviation of the hit part", gt=0.0, le=10.0)
    laser_lambda_short: float = param(0.1, "1/m", "decay rate of the short part, beam model", gt=0.0,
                                       le=100.0)
    laser_likelihood_max_dist: float = param(2.0, "m", "distances to the nearest obstacle are capped here, "
                                             "likelihood field models", ge=0.0, le=MAX_LIKELIHOOD_DIST)
    laser_model_type: str = param("likelihood_field", "", "beam, likelihood_field or likelihood_field_prob",
                                  restart=True)
    do_beamskip: bool = param(False, "", "likelihood_field_prob: once converged, skip beams most particles "
                              "find far from the map")
    beam_skip_distance: float = param(0.5, "m", "a beam end this close to an obstacle agrees with the map",
                                      ge=0.0, le=MAX_LIKELIHOOD_DIST)
    beam_skip_threshold: float = param(0.3, "", "share of particles a beam must agree for to be used",
                                       ge=0.0, le=1.0)
    beam_skip_error_threshold: float = param(0.9, "", "share of skipped beams at which all beams are used "
                                             "again (the filter may have converged wrongly)", ge=0.0, le=1.0)
    # Odometry model
    odom_model_type: str = param("diff", "", "diff, diff-corrected, omni or omni-corrected", restart=True)
    odom_alpha1: float = param(0.2, "", "rotation noise from rotation", ge=0.0, le=MAX_ALPHA)
    odom_alpha2: float = param(0.2, "", "rotation noise from translation", ge=0.0, le=MAX_ALPHA)
    odom_alpha3: float = param(0.2, "", "translation noise from translation", ge=0.0, le=MAX_ALPHA)
    odom_alpha4: float = param(0.2, "", "translation noise from rotation", ge=0.0, le=MAX_ALPHA)
    odom_alpha5: float = param(0.2, "", "strafe noise, omni models only", ge=0.0, le=MAX_ALPHA, not_for_this_robot=_OMNI)
    odom_frame_id: str = param("odom", "", "odometry frame", restart=True)
    base_frame_id: str = param("base_link", "", "robot base frame", restart=True)
    global_frame_id: str = param("map", "", "frame of the map and of the estimate", restart=True)
    # Ours
    seed: int = param(0, "", "seed of the filter's random generator (ours: ROS 1 seeds from the clock); the same "
                      "seed, map and inputs give the same particles", ge=0, le=2 ** 32 - 1,
                      restart=True)
    global_localization_candidates: int = param(15, "", "global localization and recovery put their particles "
                                                "round this many of the scan matcher's best poses over the whole "
                                                "map (ours); 0: uniformly over the free space, as amcl", ge=0,
                                                le=MAX_CANDIDATES, rounds=True)
    global_localization_uniform_share: float = param(0.1, "", "share of those particles spread uniformly over the "
                                                     "free space all the same, so that candidates that all miss "
                                                     "the robot can still be recovered from", ge=0.0, le=1.0)
    recovery_match_interval: float = param(5.0, "s", "least time (the scans' stamps) between two whole-map matches "
                                           "for recovery's injected particles (each costs 0.1-0.4 s on the lab's "
                                           "map); between them the last candidates, moved by the odometry, are "
                                           "reused", ge=0.0, le=MAX_RECOVERY_MATCH_INTERVAL)
    warnings: list[str] = field(default_factory=list)

    @property
    def motion_model(self) -> str:
        """The odometry model the filter runs: the differential one of an omni configuration."""
        return DIFF_FOR_OMNI.get(self.odom_model_type, self.odom_model_type)

    @classmethod
    def from_params(cls, given=None, where: str = "amcl") -> AmclParams:
        """Checked values of amcl's namespace (ParameterError names the key), with the relations between them."""
        given = dict(given or {})
        if "beam_skip_error_threshold_" in given:     # amcl prefers this misspelling (its cfg's) when it is set
            given["beam_skip_error_threshold"] = given.pop("beam_skip_error_threshold_")
        params, warnings = build(cls, given, where)
        params.warnings = warnings
        params.check(where)
        if params.odom_model_type in DIFF_FOR_OMNI:
            params.warnings.append(f"{where}/odom_model_type has no effect: this robot is a differential drive; "
                                   f"'{params.odom_model_type}' runs as '{params.motion_model}'")
        return params

    def check(self, where: str = "amcl") -> None:
        """ParameterError for a value of the wrong type or out of range (a configuration built by hand), outside its
        choices, or two values that contradict each other."""
        for name, spec in fields_of(AmclParams).items():
            setattr(self, name, spec.check(getattr(self, name), f"{where}/{name}"))
        if self.laser_model_type not in LASER_MODELS:
            raise ParameterError(f"{where}/laser_model_type: must be one of {', '.join(LASER_MODELS)}, "
                                 f"got {self.laser_model_type!r}")
        if self.odom_model_type not in ODOM_MODELS:
            raise ParameterError(f"{where}/odom_model_type: must be one of {', '.join(ODOM_MODELS)}, "
                                 f"got {self.odom_model_type!r}")
        if self.min_particles > self.max_particles:
            raise ParameterError(f"{where}/min_particles: must not exceed max_particles ({self.max_particles}), "
                                 f"got {self.min_particles!r}")
