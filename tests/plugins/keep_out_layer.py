"""An example costmap layer: a rectangle the robot must not enter, whatever the sensors see.

One module, and its registration ``SPEC``, which a test or an application registers with
``LAYERS.register(SPEC)`` before the costmap starts.
"""

from __future__ import annotations

from dataclasses import dataclass

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.costmap.layer import Bounds, Layer
from simplebot_navigation.costmap.plugins import LayerSpec
from simplebot_navigation.parameters import param


@dataclass
class KeepOutParams:
    zone: list = param([0.0, 0.0, 0.0, 0.0], "m", "min_x, min_y, max_x, max_y in the costmap's frame")
    enabled: bool = param(True, "", "the layer takes part in updates")


class KeepOutLayer(Layer):
    def __init__(self, name: str, zone: list, enabled: bool = True):
        super().__init__(name)
        self.reconfigure(zone, enabled)

    def reconfigure(self, zone: list, enabled: bool = True) -> None:
        if len(zone) != 4 or not zone[0] <= zone[2] or not zone[1] <= zone[3]:
            raise ValueError(f"{self.name}/zone: expected [min_x, min_y, max_x, max_y], got {zone!r}")
        self.zone = [float(v) for v in zone]
        self.enabled = enabled

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float, bounds: Bounds) -> None:
        bounds.touch(self.zone[0], self.zone[1])
        bounds.touch(self.zone[2], self.zone[3])

    def update_costs(self, master, x0: int, y0: int, xn: int, yn: int) -> None:
        lo_x, lo_y = master.world_to_map_no_bounds(self.zone[0], self.zone[1])
        hi_x, hi_y = master.world_to_map_no_bounds(self.zone[2], self.zone[3])
        cols = slice(max(x0, lo_x), min(xn, hi_x + 1))
        rows = slice(max(y0, lo_y), min(yn, hi_y + 1))
        master.costmap[rows, cols] = LETHAL_OBSTACLE


SPEC = LayerSpec("KeepOutLayer", ("example::KeepOutLayer",), KeepOutLayer, KeepOutParams)
