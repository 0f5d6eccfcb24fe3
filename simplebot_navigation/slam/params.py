"""The slam node's parameters, named as slam_toolbox names them where they mean the same (docs/reference.md §13).

Defaults are slam_toolbox's (its online mapper's configuration) unless the line says "ours". slam_toolbox's
search spaces are full widths (``correlation_search_space_dimension`` 0.5 m is ±0.25 m); so are ours. Ceres' and
the interactive mode's parameters are accepted with a warning: the pose graph is optimised by gtsam here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from simplebot_navigation.parameters import ParameterError, build, fields_of, param

MODES = ("mapping", "localization")
#: ours: bounds of what a configuration may ask for (docs/reference.md §13)
MAX_RANGE = 100.0           # m: laser ranges and search distances
MAX_SEARCH = 20.0           # m: the full width of a search window
MAX_BUFFER = 1000           # scans in the running buffer or a loop chain
MAX_INTERVAL = 3600.0       # s
_SOLVER = "the pose graph is optimised by gtsam's Levenberg-Marquardt (slam/pose_graph.py), not Ceres"
_INTERACTIVE = "slam_toolbox's interactive mode (moving nodes in rviz) is not offered"
_SEARCH = ("the search steps by every heading that moves the farthest return by a cell of its grid, then refines "
           "the pose continuously")
_LOG_ODDS = "the map is kept in log-odds: occupied_threshold and free_threshold (ours) decide a cell"


@dataclass
class SlamParams:
    # Frames, topics and timing
    mode: str = param("mapping", "", "mapping (build the map) or localization (on a serialized map, which is "
                      "not extended)", restart=True)
    odom_frame: str = param("odom", "", "odometry frame", restart=True)
    map_frame: str = param("map", "", "frame of the map and of the pose graph", restart=True)
    base_frame: str = param("base_link", "", "robot base frame (slam_toolbox's default is base_footprint; "
                            "the simplebot's base is base_link)", restart=True)
    scan_topics: str = param("front_laser/front_scan back_laser/back_scan", "", "ours: the LaserScan topics, "
                             "space-separated (slam_toolbox reads one scan_topic); scans of one moment are merged",
                             restart=True)
    synchronous: bool = param(False, "", "ours: process every scan in order as it comes, as slam_toolbox's "
                              "synchronous node does (lockstep runs, tests); false: on a worker thread, dropping "
                              "scans that come while it is busy, as its asynchronous node does", restart=True)
    transform_publish_period: float = param(0.02, "s", "period of map -> odom on /tf; 0: only with each scan",
                                            ge=0.0, le=10.0)
    transform_tolerance: float = param(0.1, "s", "ours, as amcl's: how far map -> odom is post-dated after the "
                                       "scan it comes from, so that without scans it goes stale",
                                       ge=0.0, le=10.0)
    map_update_interval: float = param(5.0, "s", "period of /map (a closure publishes it at once)", gt=0.0,
                                       le=MAX_INTERVAL)
    minimum_time_interval: float = param(0.5, "s", "least time between two scans that are processed", ge=0.0,
                                         le=MAX_INTERVAL)
    throttle_scans: int = param(1, "", "process every n-th scan", ge=1, le=1000, rounds=True)
    map_file_name: str = param("", "", "a serialized session (without .posegraph.npz) loaded at start: mapping "
                               "goes on from it, or localization runs on it", restart=True)
    map_start_pose: list = param([], "", "[x, y, yaw] of the robot in the map at start (empty: where the loaded "
                                 "session began, or the odometry's pose)", restart=True)
    # Map
    resolution: float = param(0.05, "m", "cell size of /map", ge=0.01, le=1.0, restart=True)
    max_laser_range: float = param(20.0, "m", "returns beyond this are not trusted: they only clear",
                                   gt=0.0, le=MAX_RANGE)
    min_laser_range: float = param(0.0, "m", "returns closer than this are dropped (and the scan's range_min)",
                                   ge=0.0, le=MAX_RANGE)
    occupied_threshold: float = param(0.65, "", "ours: occupancy probability above which a cell of /map is "
                                      "occupied", gt=0.5, le=1.0)
    free_threshold: float = param(0.196, "", "ours: occupancy probability below which a cell of /map is free",
                                  ge=0.0, le=0.5)
    # Scan matching
    use_scan_matching: bool = param(True, "", "correct odometry by matching each scan to the recent ones")
    minimum_travel_distance: float = param(0.5, "m", "travel since the last node before a scan becomes one",
                                           ge=0.0, le=MAX_RANGE)
    minimum_travel_heading: float = param(0.5, "rad", "rotation since the last node before a scan becomes one",
                                          ge=0.0, le=2 * math.pi)
    scan_buffer_size: int = param(10, "", "recent nodes a scan is matched against", ge=1, le=MAX_BUFFER,
                                  rounds=True)
    scan_buffer_maximum_scan_distance: float = param(10.0, "m", "recent nodes further than this from the robot "
                                                     "leave the buffer", gt=0.0, le=MAX_RANGE)
    link_match_minimum_response_fine: float = param(0.1, "", "a match to the buffer below this response is not "
                                                    "trusted: odometry alone places the node", ge=0.0, le=1.0)
    correlation_search_space_dimension: float = param(0.5, "m", "full width of the matching window",
                                                      gt=0.0, le=MAX_SEARCH)
    correlation_search_space_smear_deviation: float = param(0.1, "m", "how far a wall's likelihood spreads "
                                                            "around it when matching", gt=0.0, le=1.0)
    coarse_search_angle_offset: float = param(0.349, "rad", "half-width of the heading window", gt=0.0,
                                              le=math.pi)
    distance_variance_penalty: float = param(0.5, "m^2", "a match d metres from odometry's guess has its response "
                                             "times 1 - 0.2 d^2 / this (Karto's penalty): where the scan cannot tell, "
                                             "along a corridor, odometry wins", gt=0.0, le=1e6)
    angle_variance_penalty: float = param(1.0, "rad^2", "the same for the heading", gt=0.0, le=1e6)
    minimum_distance_penalty: float = param(0.5, "", "the distance penalty is at least this", ge=0.0, le=1.0)
    minimum_angle_penalty: float = param(0.9, "", "the heading penalty is at least this", ge=0.0, le=1.0)
    # Loop closure
    do_loop_closing: bool = param(True, "", "look for loop closures")
    loop_search_maximum_distance: float = param(3.0, "m", "nodes this close to the robot are loop-closure "
                                                "candidates", gt=0.0, le=MAX_RANGE)
    loop_match_minimum_chain_size: int = param(10, "", "fewest consecutive candidate nodes to match against",
                                               ge=1, le=MAX_BUFFER, rounds=True)
    loop_match_minimum_response_coarse: float = param(0.35, "", "response the coarse loop search must reach",
                                                      ge=0.0, le=1.0)
    loop_match_minimum_response_fine: float = param(0.45, "", "response the refined loop match must reach",
                                                    ge=0.0, le=1.0)
    loop_search_space_dimension: float = param(8.0, "m", "full width of the loop-closure window", gt=0.0,
                                               le=MAX_SEARCH)
    loop_search_space_smear_deviation: float = param(0.03, "m", "how far a wall's likelihood spreads when "
                                                     "matching a loop", gt=0.0, le=1.0)
    # Accepted, without effect here
    solver_plugin: str = param("solver_plugins::CeresSolver", "", "pose graph solver", not_implemented=_SOLVER)
    ceres_linear_solver: str = param("SPARSE_NORMAL_CHOLESKY", "", "Ceres linear solver", not_implemented=_SOLVER)
    ceres_preconditioner: str = param("SCHUR_JACOBI", "", "Ceres preconditioner", not_implemented=_SOLVER)
    ceres_trust_strategy: str = param("LEVENBERG_MARQUARDT", "", "Ceres trust region", not_implemented=_SOLVER)
    ceres_loss_function: str = param("None", "", "Ceres loss; here matching edges always have a Cauchy kernel",
                                     not_implemented=_SOLVER)
    enable_interactive_mode: bool = param(True, "", "rviz interactive markers", not_implemented=_INTERACTIVE)
    ceres_dogleg_type: str = param("TRADITIONAL_DOGLEG", "", "Ceres dogleg", not_implemented=_SOLVER)
    scan_topic: str = param("/scan", "", "slam_toolbox's one laser topic", not_implemented="scan_topics (ours) "
                            "names the topics, both lidars by default", restart=True)
    map_name: str = param("/map", "", "topic of the map", not_implemented="the map goes out on map (remap it)")
    debug_logging: bool = param(False, "", "verbose logs", not_implemented="the node logs at its log level "
                                "(--ros-args --log-level)")
    transform_timeout: float = param(0.2, "s", "how long a scan waits for its odometry transform before it is "
                                     "dropped", ge=0.0, le=10.0)
    tf_buffer_duration: float = param(30.0, "s", "TF buffer length", ge=0.0, le=MAX_INTERVAL,
                                      not_implemented="the transform buffer keeps tf2's 10 s")
    stack_size_to_use: int = param(40_000_000, "", "thread stack size", ge=0, le=2 ** 31 - 1,
                                   not_implemented="nothing here recurses deeply")
    scan_queue_size: int = param(1, "", "scans queued while busy", ge=0, le=1000,
                                 not_implemented="asynchronous: a scan that comes while the mapper is busy is dropped")
    use_scan_barycenter: bool = param(True, "", "measure travel from the scan's barycenter",
                                      not_implemented="travel is the base frame's, from odometry")
    link_scan_maximum_distance: float = param(1.5, "m", "nodes within this are linked to a new one", ge=0.0,
                                              le=MAX_RANGE,
                                              not_implemented="a new node is linked to the last one (and to loops)")
    fine_search_angle_offset: float = param(0.00349, "rad", "heading window of the fine search", ge=0.0,
                                            le=math.pi, not_implemented=_SEARCH)
    coarse_angle_resolution: float = param(0.0349, "rad", "heading step of the coarse search", ge=0.0, le=math.pi,
                                           not_implemented=_SEARCH)
    correlation_search_space_resolution: float = param(0.01, "m", "cell of the matching grid (and of the fine loop "
                                                       "match): the search's step, before the continuous refinement",
                                                       ge=0.005, le=1.0)
    loop_search_space_resolution: float = param(0.05, "m", "cell of the coarse loop search's grid", ge=0.005,
                                                le=1.0)
    loop_match_maximum_variance_coarse: float = param(3.0, "", "largest covariance of an accepted coarse loop "
                                                      "match", ge=0.0, le=1e6,
                                                      not_implemented="a closure must pass the fine match's response")
    use_response_expansion: bool = param(True, "", "widen the search when the response is low",
                                         not_implemented="the window is searched exhaustively once")
    min_pass_through: int = param(2, "", "beams through a cell before it counts", ge=0, le=1000,
                                  not_implemented=_LOG_ODDS)
    occupancy_threshold: float = param(0.1, "", "share of hits to passes for an occupied cell", ge=0.0, le=1.0,
                                       not_implemented=_LOG_ODDS)
    map_start_at_dock: bool = param(False, "", "start at the dock of a loaded session",
                                    not_implemented="map_start_pose or initialpose place the robot")
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_params(cls, given=None, where: str = "slam") -> SlamParams:
        """Checked values of the node's namespace (ParameterError names the key), and their relations."""
        params, warnings = build(cls, dict(given or {}), where)
        params.warnings = warnings
        params.check(where)
        return params

    def check(self, where: str = "slam") -> None:
        for name, spec in fields_of(SlamParams).items():
            setattr(self, name, spec.check(getattr(self, name), f"{where}/{name}"))
        if self.mode not in MODES:
            raise ParameterError(f"{where}/mode: must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.map_start_pose and (len(self.map_start_pose) != 3 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and abs(v) <= 1e6
                for v in self.map_start_pose)):
            raise ParameterError(f"{where}/map_start_pose: expected [] or [x, y, yaw] (finite, within 1e6), got "
                                 f"{self.map_start_pose!r}")
        if self.mode == "localization" and not self.map_file_name:
            self.warnings.append(f"{where}/mode: localization needs a map: set map_file_name, or call "
                                 "deserialize_map; until then scans are not used")
        if self.min_laser_range >= self.max_laser_range:
            raise ParameterError(f"{where}/min_laser_range: must be below max_laser_range "
                                 f"({self.max_laser_range:g}), got {self.min_laser_range!r}")
        if self.loop_match_minimum_response_fine < self.loop_match_minimum_response_coarse:
            raise ParameterError(f"{where}/loop_match_minimum_response_fine: must not be below "
                                 f"loop_match_minimum_response_coarse ({self.loop_match_minimum_response_coarse:g}), "
                                 f"got {self.loop_match_minimum_response_fine!r}")


@dataclass
class ExploreParams:
    """explore_lite's parameters (its defaults), for the explore node (ros/slam/explore_node.py)."""
    robot_base_frame: str = param("base_link", "", "the robot's frame, looked up in the map's frame", restart=True)
    costmap_topic: str = param("map", "", "the OccupancyGrid to explore (explore_lite reads the global costmap; here "
                               "the slam node's map, whose unknown cells are the frontiers' other side)", restart=True)
    planner_frequency: float = param(0.33, "Hz", "how often the frontiers are searched and a goal chosen",
                                     gt=0.0, le=100.0)
    progress_timeout: float = param(30.0, "s", "a goal the robot gets no closer to for this long is given up",
                                    gt=0.0, le=MAX_INTERVAL)
    potential_scale: float = param(3.0, "", "weight of the travel distance to a frontier", ge=0.0, le=1e3)
    gain_scale: float = param(1.0, "", "weight of a frontier's size", ge=0.0, le=1e3)
    orientation_scale: float = param(0.0, "", "weight of the turn towards a frontier",
                                     not_implemented="explore_lite never uses it either: the goal's heading is "
                                     "the robot's way to it")
    min_frontier_size: float = param(0.5, "m", "frontiers shorter than this are left out", ge=0.0, le=MAX_RANGE)
    transform_tolerance: float = param(0.3, "s", "how old the robot's pose in the map may be", ge=0.0, le=10.0)
    visualize: bool = param(True, "", "publish the frontiers as markers on ~/frontiers")
    # Ours
    clearance: float = param(0.35, "m", "ours: frontiers are reached over cells this far from obstacles (the robot's "
                             "inscribed radius and a margin)", gt=0.0, le=5.0)
    blacklist_radius: float = param(0.5, "m", "ours: a frontier whose goal is this close to a goal given up is left "
                                    "out", ge=0.0, le=MAX_RANGE)
    save_map: str = param("explored", "", "ours: when no frontier is left, slam's save_map writes the map under "
                          "this name (YAML + image; relative to the working directory); empty: not saved")
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_params(cls, given=None, where: str = "explore") -> ExploreParams:
        params, warnings = build(cls, dict(given or {}), where)
        params.warnings = warnings
        for name, spec in fields_of(ExploreParams).items():
            setattr(params, name, spec.check(getattr(params, name), f"{where}/{name}"))
        return params
