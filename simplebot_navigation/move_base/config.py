"""move_base parameters with their effective ROS 1 defaults (REFERENCE §1.2)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

DEFAULT_RECOVERY_BEHAVIORS = (
    {"name": "conservative_reset", "type": "clear_costmap_recovery/ClearCostmapRecovery"},
    {"name": "rotate_recovery", "type": "rotate_recovery/RotateRecovery"},
    {"name": "aggressive_reset", "type": "clear_costmap_recovery/ClearCostmapRecovery"},
)
RECOVERY_TYPES = ("clear_costmap_recovery/ClearCostmapRecovery", "rotate_recovery/RotateRecovery")


def _number(params: dict, key: str, default: float, minimum: float | None = None) -> float:
    value = params.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"move_base parameter {key}: expected a number, got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"move_base parameter {key}: must be >= {minimum}, got {value}")
    return float(value)


def _flag(params: dict, key: str, default: bool) -> bool:
    value = params.get(key, default)
    if not isinstance(value, bool):
        raise ValueError(f"move_base parameter {key}: expected true or false, got {value!r}")
    return value


@dataclass
class MoveBaseConfig:
    base_global_planner: str = "navfn/NavfnROS"
    base_local_planner: str = "base_local_planner/TrajectoryPlannerROS"
    planner_frequency: float = 0.0
    controller_frequency: float = 20.0
    planner_patience: float = 5.0
    controller_patience: float = 15.0
    max_planning_retries: int = -1
    oscillation_timeout: float = 0.0
    oscillation_distance: float = 0.5
    progress_timeout: float = 30.0   # ours, not ROS 1 (0 disables): see state_machine
    watchdog_timeout: float = 0.3    # ours (0 disables): wall seconds without a control cycle before stopping the robot
    max_wait: float = 30.0           # ours (0 disables): seconds a goal may wait for its pose, sensors or clock
    recovery_behavior_enabled: bool = True
    clearing_rotation_allowed: bool = True
    shutdown_costmaps: bool = False
    conservative_reset_dist: float = 3.0
    make_plan_clear_costmap: bool = True
    make_plan_add_unreachable_goal: bool = True
    recovery_behaviors: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> MoveBaseConfig:
        """From move_base's private ROS 1 tree; a malformed recovery list falls back to the defaults with a
        warning, as move_base does."""
        cfg = cls()
        for key in ("base_global_planner", "base_local_planner"):
            value = params.get(key, getattr(cfg, key))
            if not isinstance(value, str) or not value:
                raise ValueError(f"move_base parameter {key}: expected a plugin name, got {value!r}")
            setattr(cfg, key, value)
        cfg.planner_frequency = _number(params, "planner_frequency", cfg.planner_frequency, 0.0)
        cfg.controller_frequency = _number(params, "controller_frequency", cfg.controller_frequency, 0.0)
        if cfg.controller_frequency <= 0:
            raise ValueError("move_base parameter controller_frequency: must be > 0")
        cfg.planner_patience = _number(params, "planner_patience", cfg.planner_patience, 0.0)
        cfg.controller_patience = _number(params, "controller_patience", cfg.controller_patience, 0.0)
        retries = params.get("max_planning_retries", cfg.max_planning_retries)
        if isinstance(retries, bool) or not isinstance(retries, int) or retries < -1:
            raise ValueError(f"move_base parameter max_planning_retries: expected an int >= -1, got {retries!r}")
        cfg.max_planning_retries = retries
        cfg.oscillation_timeout = _number(params, "oscillation_timeout", cfg.oscillation_timeout, 0.0)
        cfg.oscillation_distance = _number(params, "oscillation_distance", cfg.oscillation_distance, 0.0)
        cfg.progress_timeout = _number(params, "progress_timeout", cfg.progress_timeout, 0.0)
        cfg.watchdog_timeout = _number(params, "watchdog_timeout", cfg.watchdog_timeout, 0.0)
        cfg.max_wait = _number(params, "max_wait", cfg.max_wait, 0.0)
        cfg.conservative_reset_dist = _number(params, "conservative_reset_dist", cfg.conservative_reset_dist, 0.0)
        for key in ("recovery_behavior_enabled", "clearing_rotation_allowed", "shutdown_costmaps",
                    "make_plan_clear_costmap", "make_plan_add_unreachable_goal"):
            setattr(cfg, key, _flag(params, key, getattr(cfg, key)))
        cfg.recovery_behaviors = cfg._recovery_list(params.get("recovery_behaviors"))
        return cfg

    def _recovery_list(self, given) -> list[dict]:
        if given is not None:
            problem = None
            if not isinstance(given, list) or not given:
                problem = f"expected a list of {{name, type}}, got {given!r}"
            else:
                names = [b.get("name") if isinstance(b, dict) else None for b in given]
                for entry, name in zip(given, names):
                    if not isinstance(entry, dict) or not name or entry.get("type") not in RECOVERY_TYPES:
                        problem = f"entry {entry!r} needs a name and a type of {', '.join(RECOVERY_TYPES)}"
                        break
                else:
                    if len(set(names)) != len(names):
                        problem = f"recovery behaviour names must be unique, got {names}"
            if problem is None:
                return [dict(b) for b in given]
            self.warnings.append(f"recovery_behaviors: {problem}; using the default recovery behaviours")
        behaviors = [dict(b) for b in DEFAULT_RECOVERY_BEHAVIORS]
        if not self.clearing_rotation_allowed:
            return [b for b in behaviors if b["type"] != "rotate_recovery/RotateRecovery"]
        return behaviors + [dict(DEFAULT_RECOVERY_BEHAVIORS[1])]  # rotate once more after the aggressive reset
