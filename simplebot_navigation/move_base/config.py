"""move_base parameters with their effective ROS 1 defaults (docs/reference.md §1.2), declared with the
parameter layer: each has a unit, a doc, a range and a status."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from simplebot_navigation.costmap.params import searched_keys
from simplebot_navigation.parameters import ParameterError, build, param
from simplebot_navigation.move_base.plugins import RECOVERY_BEHAVIORS
from simplebot_navigation.move_base.recovery.clear_costmap import CLEAR_COSTMAP_RECOVERY
from simplebot_navigation.move_base.recovery.rotate import ROTATE_RECOVERY
from simplebot_navigation.mppi.plugin import MPPI_LOCAL_PLANNER
from simplebot_navigation.planning.config import NAVFN
from simplebot_navigation.teb.plugin import TEB_LOCAL_PLANNER

DEFAULT_RECOVERY_BEHAVIORS = (
    {"name": "conservative_reset", "type": CLEAR_COSTMAP_RECOVERY},
    {"name": "rotate_recovery", "type": ROTATE_RECOVERY},
    {"name": "aggressive_reset", "type": CLEAR_COSTMAP_RECOVERY},
)


@dataclass
class MoveBaseConfig:
    base_global_planner: str = param(NAVFN, "", "global planner plugin", restart=True)
    # ROS 1's default, base_local_planner/TrajectoryPlannerROS, does not exist here: TEB is the default.
    base_local_planner: str = param(TEB_LOCAL_PLANNER, "", "local planner plugin",
                                    restart=True)
    # ours, not ROS 1: who drives when (move_base/planner_switch.py)
    crowd_local_planner: str = param(MPPI_LOCAL_PLANNER, "", "Here: the local planner that drives while moving "
                                     "obstacles are near (empty, or base_local_planner's type: that one always)",
                                     restart=True)
    crowd_distance: float = param(1.5, "m", "Here: the crowd planner drives while a moving obstacle is, or at its "
                                  "velocity within crowd_lookahead will be, this near the robot's body", ge=0,
                                  le=20.0)
    crowd_lookahead: float = param(3.0, "s", "Here: how far ahead moving obstacles' paths count for "
                                   "crowd_distance", ge=0, le=20.0)
    crowd_release_time: float = param(2.0, "s", "Here: the base planner drives again once no moving obstacle has "
                                      "been near for this long", ge=0, le=60.0)
    planner_frequency: float = param(0.0, "Hz", "replanning rate while driving (0: only when needed)", ge=0,
                                     le=100.0)
    controller_frequency: float = param(20.0, "Hz", "control loop rate", ge=0.5, le=100.0)
    planner_patience: float = param(5.0, "s", "time to find a plan before recovering", ge=0)
    controller_patience: float = param(15.0, "s", "time without a valid command before recovering", ge=0)
    max_planning_retries: int = param(-1, "", "failed plans before recovering (-1: use planner_patience)", ge=-1)
    oscillation_timeout: float = param(0.0, "s", "time without oscillation_distance progress before "
                                       "recovering (0: off)", ge=0)
    oscillation_distance: float = param(0.5, "m", "distance that resets the oscillation timer", ge=0)
    # ours, not ROS 1 (0 disables): see state_machine
    progress_timeout: float = param(30.0, "s", "abort after this long without getting closer (0: off)", ge=0)
    watchdog_timeout: float = param(0.3, "s", "wall time without a control cycle before stopping the robot "
                                    "(0: off)", ge=0)
    max_wait: float = param(30.0, "s", "time a goal may wait for its pose, sensors or clock (0: off)", ge=0)
    recovery_behavior_enabled: bool = param(True, "", "run recovery behaviours")
    clearing_rotation_allowed: bool = param(True, "", "include in-place rotations in the default recoveries",
                                            restart=True)
    shutdown_costmaps: bool = param(False, "", "stop the costmaps while there is no goal",
                                    not_implemented="the costmaps keep updating while idle")
    conservative_reset_dist: float = param(3.0, "m", "side of the square conservative_reset keeps (its "
                                           "reset_distance at start-up; change that one while running)", ge=0,
                                           restart=True)
    make_plan_clear_costmap: bool = param(True, "", "make_plan clears the robot's footprint first",
                                          not_implemented="make_plan plans on the costmap as it is")
    make_plan_add_unreachable_goal: bool = param(True, "", "make_plan appends the goal when only a nearby "
                                                 "pose is reachable", not_implemented="make_plan returns the "
                                                 "path to the reachable pose only")
    recovery_behaviors: list = param(list(DEFAULT_RECOVERY_BEHAVIORS), "", "recovery behaviours in order, as a "
                                     "list of {name, type} (unset: these, then rotate_recovery again)", restart=True)
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> MoveBaseConfig:
        """From move_base's private ROS 1 tree; a malformed recovery list falls back to the defaults with a
        warning, as move_base does. Sub-namespaces (costmaps, planners, recoveries) are read by their
        owners, so they are not reported as unknown here."""
        params = params or {}
        known = [key for key, value in params.items() if isinstance(value, dict)] + list(searched_keys())
        scalars = {key: value for key, value in params.items() if key != "recovery_behaviors"}
        cfg, cfg.warnings = build(cls, scalars, "move_base", also_known=known + ["recovery_behaviors"])
        for key in ("base_global_planner", "base_local_planner"):
            if not getattr(cfg, key):
                raise ParameterError(f"move_base/{key}: expected a plugin name, got ''")
        cfg.recovery_behaviors = cfg._recovery_list(params.get("recovery_behaviors"))
        return cfg

    def _recovery_list(self, given) -> list[dict]:
        if given is not None:
            problem = None
            if not isinstance(given, list) or not given:
                problem = f"expected a list of {{name, type}}, got {given!r}"
            else:
                names = [b.get("name") if isinstance(b, dict) else None for b in given]
                known = RECOVERY_BEHAVIORS.types
                for entry, name in zip(given, names):
                    if not isinstance(entry, dict) or not name or entry.get("type") not in known:
                        problem = f"entry {entry!r} needs a name and a type of {', '.join(known)}"
                        break
                else:
                    if len(set(names)) != len(names):
                        problem = f"recovery behaviour names must be unique, got {names}"
            if problem is None:
                return [dict(b) for b in given]
            self.warnings.append(f"move_base/recovery_behaviors: {problem}; using the default recovery behaviours")
        behaviors = [dict(b) for b in DEFAULT_RECOVERY_BEHAVIORS]
        if not self.clearing_rotation_allowed:
            return [b for b in behaviors if b["type"] != ROTATE_RECOVERY]
        return behaviors + [dict(DEFAULT_RECOVERY_BEHAVIORS[1])]  # rotate once more after the aggressive reset
