"""CostmapCore: everything Costmap2DROS does except talking to ROS.

Four classes make a costmap, each with one job: Costmap2D is a grid of costs; LayeredCostmap keeps the master
grid and combines its layers into it; CostmapCore (a LayeredCostmap) builds the layers from the parameter
tree and routes sensor data and live changes to them; Costmap2DROS (ros/costmap/) is the ROS shell around it.

The ROS shell owns subscriptions, TF and publishing; it calls this class with plain data:

    cm = CostmapCore("local_costmap", params, parents=[("/move_base", move_base_params)], clock=node_seconds)
    for layer, source in cm.observation_sources(): subscribe to source.topic ...
    cm.add_laser_scan("front_laser", ranges, angle_min, angle_increment, range_min, range_max,
                      sensor_pose=(x, y, z, yaw), stamp=t)         # pose in cm.config.global_frame
    cm.update_map(x, y, yaw)                                       # robot pose in the global frame
    cm.costmap.costmap, cm.update_window, cm.is_current(), cm.stale_sources()
"""

from __future__ import annotations

import time

import numpy as np

from simplebot_navigation.parameters import fields_of
from simplebot_navigation.costmap.footprint import pad_footprint, transform_footprint
from simplebot_navigation.costmap.layer import CostmapLayer, MapLayer, MovingObstacleClearing, SensorLayer
from simplebot_navigation.costmap.layered_costmap import LayeredCostmap
from simplebot_navigation.costmap.observation import (Observation, ObservationBuffer, ObservationSource,
                                                      laser_scan_to_observation, point_cloud_to_observation)
from simplebot_navigation.costmap.params import CostmapConfig, live_layer_params, resolve_costmap_params
from simplebot_navigation.costmap.plugins import LAYERS


class CostmapCore(LayeredCostmap):
    """The pure core of a Costmap2DROS: a LayeredCostmap built from a costmap's parameter tree, its layers fed
    with sensor data by source name, changed live by a new configuration."""

    def __init__(self, name: str, params: dict, parents=(), clock=time.monotonic):
        self.name = name
        self.config: CostmapConfig = resolve_costmap_params(params, name, parents)
        #: messages for the shell to log once at start-up
        self.warnings: list[str] = list(self.config.warnings)
        c = self.config
        period = 1.0 / c.update_frequency if c.update_frequency > 0 else 0.0
        super().__init__(c.rolling_window, c.track_unknown_space, c.size_x, c.size_y, c.resolution, c.origin_x,
                         c.origin_y, clock=clock, update_period=period)
        for plugin in c.plugins:
            self.add_plugin(LAYERS.create(plugin.name, plugin.kind, plugin.params))
        self.unpadded_footprint = c.footprint
        self.set_unpadded_footprint(c.footprint)

    # -- observations -------------------------------------------------------------
    def observation_sources(self) -> list[tuple[str, ObservationSource]]:
        """(layer name, source) for every observation source, in configuration order."""
        return [(layer.name, buffer.source) for layer in self._sensor_layers() for buffer in layer.buffers.values()]

    def _find_source(self, source: str) -> tuple[SensorLayer, ObservationSource]:
        """A source by name, or by '<layer>/<source>' when several sensor layers share a name."""
        layer_name, _, source_name = source.rpartition("/")
        matches = [(layer, buffer.source) for layer in self._sensor_layers()
                   for name, buffer in layer.buffers.items()
                   if name == source_name and layer_name in ("", layer.name)]
        if len(matches) != 1:
            known = [f"{layer}/{src.name}" for layer, src in self.observation_sources()]
            reason = "is ambiguous" if matches else "is unknown"
            raise KeyError(f"costmap {self.name!r}: observation source {source!r} {reason}; sources are {known}")
        return matches[0]

    def observation_buffer(self, source: str) -> ObservationBuffer:
        """The buffer of one source, for reporting how long it has been silent."""
        layer, src = self._find_source(source)
        return layer.buffers[src.name]

    def restart_staleness_clocks(self, now: float) -> None:
        """Every source counts as just heard from: waiting for TF or the clock is not its fault."""
        for layer in self._sensor_layers():
            for buffer in layer.buffers.values():
                buffer.reset_last_updated(now)

    def static_layers(self) -> list[MapLayer]:
        """The layers that read a map topic, for the shell to subscribe."""
        return [layer for layer in self.plugins if isinstance(layer, MapLayer)]

    def _sensor_layers(self) -> list[SensorLayer]:
        return [layer for layer in self.plugins if isinstance(layer, SensorLayer)]

    def add_observation(self, source: str, observation: Observation) -> None:
        layer, src = self._find_source(source)
        layer.add_observation(src.name, observation)

    def add_laser_scan(self, source: str, ranges, angle_min: float, angle_increment: float, range_min: float,
                       range_max: float, sensor_pose, stamp: float, sensor_rotation=None) -> None:
        """A LaserScan whose sensor pose (x, y, z, yaw) is in the costmap's global frame. A sensor that
        is tilted or upside down gives its 3x3 sensor_rotation instead; sensor_pose is then its (x, y, z)."""
        layer, src = self._find_source(source)
        if sensor_rotation is None:
            observation = laser_scan_to_observation(ranges, angle_min, angle_increment, range_min, range_max,
                                                    sensor_pose, stamp, src.obstacle_range, src.raytrace_range,
                                                    src.inf_is_valid)
        else:
            local = laser_scan_to_observation(ranges, angle_min, angle_increment, range_min, range_max,
                                              (0.0, 0.0, 0.0, 0.0), stamp, src.obstacle_range, src.raytrace_range,
                                              src.inf_is_valid)
            origin = np.asarray(sensor_pose[:3], dtype=float)
            rotation = np.asarray(sensor_rotation, dtype=float)
            observation = Observation(origin, local.points @ rotation.T + origin, local.obstacle_range,
                                      local.raytrace_range, local.stamp, local.clear_points @ rotation.T + origin)
        layer.add_observation(src.name, observation)

    def add_point_cloud(self, source: str, points_xyz, sensor_origin, stamp: float) -> None:
        """Cloud points and sensor origin already in the costmap's global frame."""
        layer, src = self._find_source(source)
        layer.add_observation(src.name, point_cloud_to_observation(points_xyz, sensor_origin, stamp,
                                                                   src.obstacle_range, src.raytrace_range))

    def set_clearing_circles(self, circles) -> None:
        """Where moving obstacles are and just were ((K, 3) x, y, radius in the global frame): every layer
        that satisfies MovingObstacleClearing (an obstacle layer) clears its marks there from the next update
        on, until the next call (docs/reference.md §6.3)."""
        for layer in self.plugins:
            if isinstance(layer, MovingObstacleClearing):
                layer.set_clearing_circles(circles)

    # -- updates ------------------------------------------------------------------
    def forget_history(self) -> None:
        """After time jumped back: reset every layer and drop every buffered observation, whose stamps
        belong to a timeline that no longer exists."""
        self.reset_layers()
        for layer in self._sensor_layers():
            layer.clear_observations()

    def clear_layers_outside(self, robot_x: float, robot_y: float, reset_distance: float,
                             layer_names=None, invert_area: bool = False) -> list[str]:
        """clear_costmap_recovery on this costmap: in each named layer (default: every sensor layer with a grid),
        forget everything outside the reset_distance square around the robot (inside with
        invert_area), and schedule the whole layer for the next update. Returns the layers cleared."""
        layers = [layer for layer in self.plugins if isinstance(layer, CostmapLayer)
                  and (isinstance(layer, SensorLayer) if layer_names is None else layer.name in layer_names)]
        for layer in layers:
            start_x, start_y = layer.world_to_map_no_bounds(robot_x - reset_distance / 2,
                                                            robot_y - reset_distance / 2)
            end_x, end_y = layer.world_to_map_no_bounds(robot_x - reset_distance / 2 + reset_distance,
                                                        robot_y - reset_distance / 2 + reset_distance)
            layer.clear_area(start_x, start_y, end_x, end_y, invert_area)
            layer.add_extra_bounds(layer.origin_x, layer.origin_y, layer.origin_x + layer.size_in_meters_x,
                                   layer.origin_y + layer.size_in_meters_y)
        return [layer.name for layer in layers]

    # -- run-time changes ---------------------------------------------------------
    def reconfigure(self, new: CostmapConfig) -> list[str]:
        """Take a configuration resolved from a changed tree: the costmap's and each layer's parameters that
        may change while running (the rest must be as before; the parameter layer refuses changing them).
        Returns the costmap-level names that changed ('footprint' for the footprint, robot_radius or
        padding), for the ROS shell to apply what it owns (its timers)."""
        c = self.config
        changed = [key for key, spec in fields_of(CostmapConfig).items()
                   if spec.dynamic and getattr(new, key) != getattr(c, key)]
        for key in changed:
            setattr(c, key, getattr(new, key))
        self.update_period = 1.0 / c.update_frequency if c.update_frequency > 0 else 0.0
        if c.robot_radius != new.robot_radius or not np.array_equal(c.footprint, new.footprint):
            c.footprint, c.robot_radius = new.footprint, new.robot_radius
            self.set_unpadded_footprint(new.footprint)
            changed.append("footprint")
        elif "footprint_padding" in changed:    # a footprint from the footprint topic keeps its outline
            self.set_unpadded_footprint(self.unpadded_footprint)
            changed.append("footprint")
        for plugin, running in zip(new.plugins, c.plugins):
            live = live_layer_params(plugin)
            self.layer(plugin.name).reconfigure(**live)
            own = fields_of(LAYERS.spec(plugin.kind).params)     # the rest (sources) the layer keeps itself
            running.params.update({key: value for key, value in live.items() if key in own})
        return changed

    # -- footprint ----------------------------------------------------------------
    def set_unpadded_footprint(self, points) -> None:
        """New footprint (e.g. from the footprint topic); padding is applied here."""
        self.unpadded_footprint = np.asarray(points, dtype=float).reshape(-1, 2)
        self.set_footprint(pad_footprint(self.unpadded_footprint, self.config.footprint_padding))

    def oriented_footprint(self, x: float, y: float, yaw: float) -> np.ndarray:
        return transform_footprint(self.footprint, x, y, yaw)


_WARM_UP_PARAMS = {
    "width": 2, "height": 2, "resolution": 0.1, "rolling_window": True, "robot_radius": 0.2,
    "plugins": [{"name": "obstacles", "type": "costmap_2d::ObstacleLayer"},
                {"name": "inflation", "type": "costmap_2d::InflationLayer"}],
    "obstacles": {"observation_sources": "scan", "scan": {"data_type": "LaserScan", "clearing": True}},
}


def warm_up() -> None:
    """Load the compiled kernels now: the first update otherwise takes about half a second,
    long enough to make sensors look stale when a node starts."""
    cm = CostmapCore("warm_up", _WARM_UP_PARAMS)
    cm.add_laser_scan("scan", np.full(8, 0.5), -1.0, 0.25, 0.1, 1.0, (0.0, 0.0, 0.0, 0.0), 0.0)
    cm.update_map(0.0, 0.0, 0.0)
