"""clear_costmap_recovery/ClearCostmapRecovery: forget obstacles away from the robot."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from simplebot_navigation.pluginlib import PluginSpec
from simplebot_navigation.parameters import PLUGIN_TYPE_KEY, ParameterError, build, param
from simplebot_navigation.move_base.recovery import RecoveryContext, RecoveryStep

CLEAR_COSTMAP_RECOVERY = "clear_costmap_recovery/ClearCostmapRecovery"

@dataclass
class ClearCostmapParams:
    """The ``<name>/`` namespace of a clear_costmap_recovery/ClearCostmapRecovery."""
    reset_distance: float = param(3.0, "m", "side of the square kept (default: conservative_reset_dist for "
                                  "conservative_reset, else 4 x the circumscribed radius)", ge=0)
    invert_area_to_clear: bool = param(False, "", "clear inside the square instead of outside")
    force_updating: bool = param(False, "", "update the costmap right after clearing")
    affected_maps: str = param("both", "", "costmaps to clear: local, global or both")
    layer_names: list = param(None, "", "layers to clear (default: every obstacle-type layer)", kind=list)


class ClearCostmapRecovery:
    """Forget obstacles outside a square of side reset_distance around the robot (inside with invert).

    clear(costmap, x, y, reset_distance, layer_names, invert) is called for each affected costmap.
    Unlike ROS 1, layer_names defaults to every obstacle-type layer that exists (docs/design.md §9).
    """

    def __init__(self, name: str, params: dict, costmaps: dict[str, object],
                 clear: Callable[..., list[str]], default_reset_distance: float):
        self.name = name
        self._all_costmaps = costmaps
        self._default_reset_distance = default_reset_distance
        self._clear = clear
        self.cleared: list[str] = []
        self.warnings = self.configure(params)

    def configure(self, params: dict) -> list[str]:
        """Take the behaviour's parameters (at start-up, and when they change while running); the warnings."""
        p, warnings = build(ClearCostmapParams, params, f"move_base/{self.name}", also_known=[PLUGIN_TYPE_KEY])
        if p.layer_names is not None and not all(isinstance(n, str) for n in p.layer_names):
            raise ParameterError(f"move_base/{self.name}/layer_names: expected a list of layer names, "
                                 f"got {p.layer_names!r}")
        self.reset_distance = p.reset_distance if "reset_distance" in params else self._default_reset_distance
        self.invert_area = p.invert_area_to_clear
        self.force_updating = p.force_updating
        self.affected_maps = affected = p.affected_maps
        if affected not in ("local", "global", "both"):
            warnings.append(f"move_base/{self.name}/affected_maps: {affected!r} is not local, global or both; "
                            "using both")
            affected = "both"
        self.costmaps = [cm for key, cm in self._all_costmaps.items() if affected == "both" or key == affected]
        self.layer_names = p.layer_names
        return warnings

    def parameters(self) -> dict:
        """The parameters it runs with, under their names (to declare on the node)."""
        values = {"reset_distance": self.reset_distance, "invert_area_to_clear": self.invert_area,
                  "force_updating": self.force_updating, "affected_maps": self.affected_maps}
        return values if self.layer_names is None else {**values, "layer_names": list(self.layer_names)}

    def start(self, now: float, pose) -> None:
        self.cleared = []
        for costmap in self.costmaps:
            self.cleared += self._clear(costmap, pose[0], pose[1], self.reset_distance, self.layer_names,
                                        self.invert_area, self.force_updating)

    def tick(self, now: float, pose) -> RecoveryStep:
        what = ", ".join(self.cleared) or "no layer"
        side = "inside" if self.invert_area else "outside"
        return RecoveryStep(None, True, f"{self.name}: cleared {what} {side} a {self.reset_distance:.2f} m square")


def create(context: RecoveryContext, name: str, params: dict) -> ClearCostmapRecovery:
    """ROS 1's defaults: conservative_reset keeps move_base's conservative_reset_dist, others 4 circumscribed radii."""
    default_distance = (context.conservative_reset_dist if name == "conservative_reset"
                        else 4.0 * context.circumscribed_radius)
    return ClearCostmapRecovery(name, params, context.costmaps, context.clear_costmap, default_distance)


SPEC = PluginSpec(CLEAR_COSTMAP_RECOVERY, create, ClearCostmapParams)
