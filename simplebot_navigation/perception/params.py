"""The obstacle tracker's parameters (move_base's ``obstacle_tracking.*``; docs/reference.md §6)."""

from __future__ import annotations

from dataclasses import dataclass, field

from simplebot_navigation.parameters import ParameterError, build, param


@dataclass
class TrackerParams:
    enabled: bool = param(False, "", "track moving obstacles in the lidar scans, hand them to the local planner "
                          "and clear their marks from the costmaps")
    min_points: int = param(3, "", "a cluster of fewer returns is noise and dropped", ge=1, le=100)
    breakpoint_angle: float = param(0.17, "rad", "adaptive breakpoint: the flattest angle between beam and surface "
                                    "at which neighbouring returns still belong to one surface", gt=0.0, le=1.4)
    breakpoint_distance: float = param(0.05, "m", "neighbouring returns closer than this always belong together",
                                       ge=0.0, le=1.0)
    range_noise: float = param(0.01, "m", "lidar range noise (1 sigma); three of it widen every breakpoint",
                               ge=0.0, le=0.5)
    max_obstacle_size: float = param(1.2, "m", "clusters wider than this are static structure (walls), never "
                                     "tracked", gt=0.0, le=10.0)
    structure_time: float = param(1.0, "s", "returns that keep landing on the same 0.1 m cells for about this "
                                  "long mark structure, and clusters lying on it are never tracked (pieces of a wall a "
                                  "moving robot sees break up); 0: off", ge=0.0, le=10.0)
    association_gate: float = param(0.6, "m", "farthest a cluster centre may lie from a track's predicted "
                                    "centre to update it", gt=0.0, le=5.0)
    max_obstacle_speed: float = param(3.0, "m/s", "fastest obstacle tracked: a track seen once that would have "
                                      "to move faster to reach a cluster starts again there (a tree seen past "
                                      "another, two neighbours seen as one), as does a moving one whose cluster "
                                      "lies far outside its prediction; at least a slow walk, or nothing could "
                                      "ever get a velocity", ge=0.5, le=20.0)
    acceleration_noise: float = param(0.5, "m/s^2", "process noise of the steady motion model (constant velocity, "
                                      "1 sigma): walking on", gt=0.0, le=50.0)
    manoeuvre_noise: float = param(4.0, "m/s^2", "process noise of the manoeuvre model (constant velocity, 1 "
                                   "sigma): turning, speeding up and slowing down; at least acceleration_noise",
                                   gt=0.0, le=50.0)
    measurement_noise: float = param(0.03, "m", "noise of a whole cluster's centre (1 sigma)", gt=0.0, le=1.0)
    initial_speed_sigma: float = param(2.0, "m/s", "velocity uncertainty of a track seen once (1 sigma): what it "
                                       "reports, and how far its second sighting may lie", gt=0.0, le=10.0)
    confirm_hits: int = param(1, "", "updates a new track needs before it is reported (1: at first sight)", ge=1,
                              le=100)
    max_missed: int = param(3, "", "scans in a row that should have seen a track, and did not, before it is "
                            "deleted", ge=1, le=100)
    max_coast_time: float = param(2.5, "s", "a track unseen this long is deleted; hidden behind something nearer "
                                  "it coasts until then, its covariance growing", gt=0.0, le=10.0)
    moving_speed: float = param(0.2, "m/s", "a track turns moving once its speed less moving_confidence sigmas "
                                "stays above this for moving_hold", gt=0.0, le=10.0)
    moving_confidence: float = param(2.0, "", "sigmas of the speed (along the velocity) by which it must exceed "
                                     "moving_speed; a velocity needs two displacements first", ge=0.0, le=10.0)
    static_speed: float = param(0.1, "m/s", "a moving track turns static once its speed stays below this for "
                                "moving_hold (below moving_speed)", ge=0.0, le=10.0)
    moving_hold: float = param(0.0, "s", "how long a speed must hold to change the moving flag", ge=0.0, le=10.0)
    clearing_time: float = param(1.5, "s", "the costmaps clear where a moving track was during this long",
                                 ge=0.0, le=10.0)
    clearing_displacement: float = param(0.25, "m", "a moving track's marks are cleared once it is this far from "
                                         "where it was first seen (a static thing taken for moving for a moment, a "
                                         "tree seen past another, keeps its marks)", ge=0.0, le=5.0)
    clearing_margin: float = param(0.1, "m", "added to a track's radius where its marks are cleared (the "
                                   "costmap adds one cell more)", ge=0.0, le=1.0)
    external_timeout: float = param(0.5, "s", "obstacles another node publishes on the local planner's "
                                    "obstacles topic are used for this long", gt=0.0, le=10.0)
    static_map_topic: str = param("/map", "", "a map (nav_msgs/OccupancyGrid) whose occupied cells are known to be "
                                  "static: returns on them start no track and turn none moving (empty: none)",
                                  restart=True)
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_params(cls, given, where: str = "move_base/obstacle_tracking") -> TrackerParams:
        """Checked values of one namespace (ParameterError names the key), with the relations between them."""
        params, warnings = build(cls, given, where)
        params.warnings = warnings
        if params.static_speed >= params.moving_speed:
            raise ParameterError(f"{where}/static_speed: must be below moving_speed ({params.moving_speed:g}), "
                                 f"got {params.static_speed!r}")
        if params.manoeuvre_noise < params.acceleration_noise:
            raise ParameterError(f"{where}/manoeuvre_noise: must be at least acceleration_noise "
                                 f"({params.acceleration_noise:g}), got {params.manoeuvre_noise!r}")
        return params
