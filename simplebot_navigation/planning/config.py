"""Parameters of global_planner/GlobalPlanner and navfn/NavfnROS (REFERENCE §3.1, §3.3).

Built from the planner's ROS 1 parameter namespace (e.g. the ``GlobalPlanner:`` block of the
lab's global_planner.yaml). Defaults are the effective ROS 1 defaults: the dynamic_reconfigure
cfg values for the reconfigurable ones, the ``param()`` fallbacks for the rest. A wrong type or
an out-of-range value raises ValueError naming the parameter; so does an unknown key, because
ROS 1 would silently ignore a misspelt one (``use_dijstra: false``) and plan with the default.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, fields

GLOBAL_PLANNER = "global_planner/GlobalPlanner"
NAVFN = "navfn/NavfnROS"


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
    use_dijkstra: bool = True
    use_quadratic: bool = True
    use_grid_path: bool = False
    allow_unknown: bool = True
    lethal_cost: int = 253
    neutral_cost: int = 50
    cost_factor: float = 3.0
    orientation_mode: OrientationMode = OrientationMode.FORWARD
    orientation_window_size: int = 1
    outline_map: bool = True
    publish_potential: bool = True
    publish_scale: int = 100
    default_tolerance: float = 0.0
    old_navfn_behavior: bool = False
    planner_window_x: float = 0.0
    planner_window_y: float = 0.0
    navfn: bool = False

    @classmethod
    def from_params(cls, params: dict | None = None) -> "GlobalPlannerConfig":
        """global_planner/GlobalPlanner parameters from a ROS-1-style dict."""
        return _build(cls, params or {}, _GLOBAL_PLANNER_SPECS, "GlobalPlanner", navfn=False)

    @classmethod
    def from_navfn_params(cls, params: dict | None = None) -> "GlobalPlannerConfig":
        """navfn/NavfnROS parameters (allow_unknown, default_tolerance, visualize_potential, ...)."""
        return _build(cls, params or {}, _NAVFN_SPECS, "NavfnROS", navfn=True)


# name -> (kind, min, max); kind is bool, int or float. Ranges are the cfg ranges.
_GLOBAL_PLANNER_SPECS = {
    "use_dijkstra": (bool, None, None),
    "use_quadratic": (bool, None, None),
    "use_grid_path": (bool, None, None),
    "allow_unknown": (bool, None, None),
    "lethal_cost": (int, 1, 255),
    "neutral_cost": (int, 1, 255),
    "cost_factor": (float, 0.01, 5.0),
    "orientation_mode": (int, 0, 6),
    "orientation_window_size": (int, 1, 255),
    "outline_map": (bool, None, None),
    "publish_potential": (bool, None, None),
    # The potential grid is int8: a larger scale overflows it.
    "publish_scale": (int, 1, 127),
    "default_tolerance": (float, 0.0, None),
    "old_navfn_behavior": (bool, None, None),
    # Read but unused by ROS 1; accepted so that configs carrying them still load.
    "planner_window_x": (float, None, None),
    "planner_window_y": (float, None, None),
}

_NAVFN_SPECS = {
    "allow_unknown": (bool, None, None),
    "default_tolerance": (float, 0.0, None),
    # navfn's name for publishing the potential.
    "visualize_potential": (bool, None, None),
    "planner_window_x": (float, None, None),
    "planner_window_y": (float, None, None),
}


def _check(namespace: str, name: str, value, kind, lo, hi):
    where = f"{namespace}/{name}"
    if kind is bool:
        if not isinstance(value, bool):
            raise ValueError(f"parameter {where} must be a bool, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"parameter {where} must be a number, got {value!r}")
    if kind is int:
        if isinstance(value, float):
            if not value.is_integer():
                raise ValueError(f"parameter {where} must be an integer, got {value!r}")
            value = int(value)
    else:
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"parameter {where} must be finite, got {value!r}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        bounds = f"[{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise ValueError(f"parameter {where} = {value!r} is out of range {bounds}")
    return value


def _build(cls, params: dict, specs: dict, namespace: str, navfn: bool) -> GlobalPlannerConfig:
    if not isinstance(params, dict):
        raise ValueError(f"{namespace} parameters must be a dict, got {type(params).__name__}")
    unknown = sorted(set(params) - set(specs))
    if unknown:
        raise ValueError(f"unknown {namespace} parameter(s) {', '.join(map(str, unknown))}; "
                         f"known: {', '.join(sorted(specs))}")
    values = {name: _check(namespace, name, value, *specs[name]) for name, value in params.items()}
    if navfn:
        publish = values.pop("visualize_potential", False)
        # navfn has no orientation filter (identity orientations) and always blocks the border
        # in its own copy of the costs, without writing into the costmap.
        values.update(publish_potential=publish, orientation_mode=OrientationMode.NONE,
                      outline_map=False, navfn=True)
    elif "orientation_mode" in values:
        values["orientation_mode"] = OrientationMode(values["orientation_mode"])
    known = {f.name for f in fields(cls)}
    assert set(values) <= known
    return cls(**values)
