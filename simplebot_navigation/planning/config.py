"""Parameters of global_planner/GlobalPlanner and navfn/NavfnROS (docs/reference.md §3.1, §3.3).

Built from the planner's ROS 1 parameter namespace (e.g. the ``GlobalPlanner:`` block of the
lab's global_planner.yaml). Defaults are the effective ROS 1 defaults: the dynamic_reconfigure
cfg values for the reconfigurable ones, the ``param()`` fallbacks for the rest; ranges are the
cfg ranges. Bad values raise ParameterError; unknown keys (a misspelt ``use_dijstra``, which ROS 1
would silently ignore) come back in ``warnings`` naming the closest known key.
"""

from __future__ import annotations

import dataclasses
import enum
from dataclasses import dataclass

from simplebot_navigation.parameters import build, fields_of, param

GLOBAL_PLANNER = "global_planner/GlobalPlanner"
NAVFN = "navfn/NavfnROS"

_UNUSED_IN_ROS1 = "ROS 1 reads it but never uses it either"


class OrientationMode(enum.IntEnum):
    """global_planner's OrientationFilter modes, numbered as in GlobalPlanner.cfg."""
    NONE = 0
    FORWARD = 1
    INTERPOLATE = 2
    FORWARD_THEN_INTERPOLATE = 3
    BACKWARD = 4
    LEFTWARD = 5
    RIGHTWARD = 6


@dataclass(frozen=True)
class GlobalPlannerConfig:
    """Effective planner parameters.

    ``navfn`` is not a ROS parameter: it records that the planner was selected as
    navfn/NavfnROS, which switches to navfn's cost mapping, border handling, tolerance search
    and un-oriented poses (see GlobalPlanner).
    """
    use_dijkstra: bool = param(True, "", "expand with Dijkstra (true) or A* (false)")
    use_quadratic: bool = param(True, "", "quadratic approximation of the potential (false: simple sum)")
    use_grid_path: bool = param(False, "", "follow grid edges instead of the potential's gradient")
    allow_unknown: bool = param(True, "", "plan through unknown space")
    lethal_cost: int = param(253, "cost", "cost at and above which a cell is blocked", ge=1, le=255)
    neutral_cost: int = param(50, "cost", "cost of moving through a free cell", ge=1, le=255)
    cost_factor: float = param(3.0, "", "factor applied to each costmap cost", ge=0.01, le=5.0)
    orientation_mode: int = param(OrientationMode.FORWARD, "", "how plan poses get their yaw (0 none, "
                                  "1 forward, 2 interpolate, 3 forward then interpolate, 4 backward, 5 leftward, "
                                  "6 rightward)", ge=0, le=6, kind=int)
    orientation_window_size: int = param(1, "poses", "window of the forward orientation estimate", ge=1, le=255)
    outline_map: bool = param(True, "", "block the costmap's border cells")
    publish_potential: bool = param(True, "", "publish the potential grid")
    # The potential grid is int8: a larger scale overflows it.
    publish_scale: int = param(100, "", "scale of the published potential", ge=1, le=127)
    default_tolerance: float = param(0.0, "m", "search this far around a blocked goal", ge=0)
    old_navfn_behavior: bool = param(False, "", "reproduce navfn's quirks")
    planner_window_x: float = param(0.0, "m", "planning window width", not_implemented=_UNUSED_IN_ROS1)
    planner_window_y: float = param(0.0, "m", "planning window height", not_implemented=_UNUSED_IN_ROS1)
    navfn: bool = False
    #: non-fatal findings while loading (unknown keys, parameters without effect)
    warnings: tuple = dataclasses.field(default=(), compare=False)

    @classmethod
    def from_params(cls, params: dict | None = None) -> "GlobalPlannerConfig":
        """global_planner/GlobalPlanner parameters from a ROS-1-style dict."""
        cfg, warnings = build(cls, params, "GlobalPlanner")
        return dataclasses.replace(cfg, orientation_mode=OrientationMode(cfg.orientation_mode),
                                   warnings=tuple(warnings))

    @classmethod
    def from_navfn_params(cls, params: dict | None = None) -> "GlobalPlannerConfig":
        """navfn/NavfnROS parameters (allow_unknown, default_tolerance, visualize_potential, ...)."""
        navfn, warnings = build(NavfnParams, params, "NavfnROS")
        # navfn has no orientation filter (identity orientations) and always blocks the border
        # in its own copy of the costs, without writing into the costmap.
        return cls(allow_unknown=navfn.allow_unknown, default_tolerance=navfn.default_tolerance,
                   publish_potential=navfn.visualize_potential, planner_window_x=navfn.planner_window_x,
                   planner_window_y=navfn.planner_window_y, orientation_mode=OrientationMode.NONE,
                   outline_map=False, navfn=True, warnings=tuple(warnings))


@dataclass(frozen=True)
class NavfnParams:
    """The parameters navfn/NavfnROS reads (its own names; mapped onto GlobalPlannerConfig)."""
    allow_unknown: bool = param(True, "", "plan through unknown space")
    default_tolerance: float = param(0.0, "m", "search this far around a blocked goal", ge=0)
    visualize_potential: bool = param(False, "", "publish the potential grid")
    planner_window_x: float = param(0.0, "m", "planning window width", not_implemented=_UNUSED_IN_ROS1)
    planner_window_y: float = param(0.0, "m", "planning window height", not_implemented=_UNUSED_IN_ROS1)


def parameter_specs(config: GlobalPlannerConfig) -> dict:
    """The specs of the parameters resolved_parameters gives, by name."""
    return fields_of(NavfnParams if config.navfn else GlobalPlannerConfig)


def resolved_parameters(config: GlobalPlannerConfig) -> dict:
    """The ROS 1 parameters a planner runs with, under the names its type reads them."""
    if config.navfn:
        values = {name: getattr(config, name) for name in fields_of(NavfnParams) if name != "visualize_potential"}
        return {**values, "visualize_potential": config.publish_potential}
    return {name: (int(value) if name == "orientation_mode" else value)
            for name, value in ((name, getattr(config, name)) for name in fields_of(GlobalPlannerConfig))}
