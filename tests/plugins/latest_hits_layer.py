"""An example sensor layer: lethal where the observations its sources hold hit, and nowhere else. No ray
tracing and no memory of its own: a mark lasts as long as its source's buffer keeps the observation (the
latest one, unless observation_persistence keeps more).

One module, and its registration ``SPEC``, which a test or an application registers with
``LAYERS.register(SPEC)`` before the costmap starts. Being a SensorLayerSpec, the registration resolves,
declares and passes on the observation sources (``<layer>.<source>.topic``, ...); the costmap routes each
source's messages here and reports the sources that go stale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.costmap.layer import Bounds, Layer
from simplebot_navigation.costmap.observation import Observation, ObservationBuffer, SensorLayerSpec
from simplebot_navigation.parameters import param


@dataclass
class LatestHitsParams:
    observation_sources: str = param("", "", "space-separated names of the sensor sub-namespaces", restart=True)
    enabled: bool = param(True, "", "the layer takes part in updates")


class LatestHitsLayer(Layer):
    def __init__(self, name: str, sources=(), enabled: bool = True):
        super().__init__(name)
        self.sources = list(sources)
        self.enabled = enabled
        self.buffers: dict[str, ObservationBuffer] = {}
        self.stale_sources: list[str] = []
        self.hits = np.empty((0, 2))            # (x, y) marked by the last update

    def on_initialize(self) -> None:
        now = self.layered_costmap.clock()
        self.buffers = {source.name: ObservationBuffer(source, now) for source in self.sources}

    def add_observation(self, source_name: str, observation: Observation) -> None:
        self.buffers[source_name].buffer_observation(observation, self.layered_costmap.clock())

    def clear_observations(self) -> None:
        for buffer in self.buffers.values():
            buffer.observations.clear()

    def reconfigure(self, sources: dict[str, dict] | None = None, **params) -> None:
        super().reconfigure(**params)
        for name, values in (sources or {}).items():
            for key, value in values.items():
                setattr(self.buffers[name].source, key, value)

    def update_bounds(self, robot_x: float, robot_y: float, robot_yaw: float, bounds: Bounds) -> None:
        costmap = self.layered_costmap
        self.stale_sources = [name for name, buffer in self.buffers.items()
                              if not buffer.is_current(costmap.clock(), costmap.update_period)]
        self.current = not self.stale_sources
        bounds.touch_points(self.hits[:, 0], self.hits[:, 1])        # the marks of the last update go
        hits = [self._within_range(observation) for buffer in self.buffers.values() if buffer.source.marking
                for observation in buffer.get_observations()]
        self.hits = np.concatenate(hits) if hits else np.empty((0, 2))
        bounds.touch_points(self.hits[:, 0], self.hits[:, 1])

    @staticmethod
    def _within_range(observation: Observation) -> np.ndarray:
        reach = np.linalg.norm(observation.points - observation.origin, axis=1)
        return observation.points[reach < observation.obstacle_range, :2]

    def update_costs(self, master, x0: int, y0: int, xn: int, yn: int) -> None:
        mx, my, inside = master.world_to_map_array(self.hits[:, 0], self.hits[:, 1])
        inside &= (mx >= x0) & (mx < xn) & (my >= y0) & (my < yn)
        master.costmap[my[inside], mx[inside]] = LETHAL_OBSTACLE


SPEC = SensorLayerSpec("LatestHitsLayer", ("example::LatestHitsLayer",), LatestHitsLayer, LatestHitsParams)
