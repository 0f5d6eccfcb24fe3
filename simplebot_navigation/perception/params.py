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
    acceleration_noise: float = param(1.5, "m/s^2", "process noise of the constant-velocity model of a moving "
                                      "track (1 sigma): people and crowds turn and change pace", gt=0.0, le=50.0)
    static_acceleration_noise: float = param(0.5, "m/s^2", "process noise of a track not (yet) moving (1 sigma): "
                                             "low, so that static things report ~0 velocity", gt=0.0, le=50.0)
    measurement_noise: float = param(0.03, "m", "noise of a cluster centre (1 sigma)", gt=0.0, le=1.0)
    initial_speed_sigma: float = param(1.0, "m/s", "velocity uncertainty of a new track (1 sigma)", gt=0.0,
                                       le=10.0)
    confirm_hits: int = param(3, "", "updates a new track needs before it is reported", ge=1, le=100)
    max_missed: int = param(3, "", "scans in a row that should have seen a track, and did not, before it is "
                            "deleted", ge=1, le=100)
    max_coast_time: float = param(1.0, "s", "a track unseen this long is deleted", gt=0.0, le=10.0)
    moving_speed: float = param(0.2, "m/s", "a track turns moving once its speed less one sigma stays above "
                                "this for moving_hold", gt=0.0, le=10.0)
    static_speed: float = param(0.1, "m/s", "a moving track turns static once its speed stays below this for "
                                "moving_hold (below moving_speed)", ge=0.0, le=10.0)
    moving_hold: float = param(0.3, "s", "how long a speed must hold to change the moving flag", ge=0.0, le=10.0)
    clearing_time: float = param(1.5, "s", "the costmaps clear where a moving track was during this long",
                                 ge=0.0, le=10.0)
    clearing_margin: float = param(0.1, "m", "added to a track's radius where its marks are cleared (the "
                                   "costmap adds one cell more)", ge=0.0, le=1.0)
    external_timeout: float = param(0.5, "s", "obstacles another node publishes on the local planner's "
                                    "obstacles topic are used for this long", gt=0.0, le=10.0)
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_params(cls, given, where: str = "move_base/obstacle_tracking") -> TrackerParams:
        """Checked values of one namespace (ParameterError names the key), with the relations between them."""
        params, warnings = build(cls, given, where)
        params.warnings = warnings
        if params.static_speed >= params.moving_speed:
            raise ParameterError(f"{where}/static_speed: must be below moving_speed ({params.moving_speed:g}), "
                                 f"got {params.static_speed!r}")
        return params
