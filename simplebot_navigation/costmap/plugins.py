"""Costmap layers by plugin type (ROS 1 ``costmap_2d::`` and Nav2 ``nav2_costmap_2d::`` names), each registered
once with its class, its parameter class and the costmap-level keys it inherits.

A layer is a subclass of ``Layer`` (costmap/layer.py documents every hook); one that reads a map or sensors
also satisfies ``MapLayer`` or ``SensorLayer`` there, and the ROS shell feeds it. docs/plugins.md shows how
to add one.
"""

from __future__ import annotations

from dataclasses import dataclass

from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.parameters.registry import Registry
from simplebot_navigation.costmap.inflation_layer import InflationLayer, InflationLayerParams
from simplebot_navigation.costmap.layer import Layer
from simplebot_navigation.costmap.obstacle_layer import ObstacleLayer, ObstacleLayerParams
from simplebot_navigation.costmap.static_layer import StaticLayer, StaticLayerParams

#: the prefixes both ROS generations give the built-in layers' types
_NAMESPACES = ("costmap_2d::", "nav2_costmap_2d::")


@dataclass(frozen=True)
class LayerSpec:
    kind: str                          # the class name, as the parameter tree and the logs call it
    types: tuple[str, ...]             # plugin type strings that select it
    layer: type[Layer]                 # built as layer(name, **params)
    params: type                       # the parameter dataclass of its namespace
    #: costmap-level keys copied into the layer's namespace when a plugin list is given (costmap_2d's rule)
    parent_keys: tuple[str, ...] = ()


def builtin(layer: type[Layer], params: type, parent_keys: tuple[str, ...] = ()) -> LayerSpec:
    """A spec for a layer under both costmap_2d's and Nav2's names."""
    return LayerSpec(layer.__name__, tuple(ns + layer.__name__ for ns in _NAMESPACES), layer, params, parent_keys)


class LayerRegistry(Registry[LayerSpec]):
    """Layers by kind; a type string selects one kind only."""

    def key(self, spec: LayerSpec) -> str:
        return spec.kind

    def conflict(self, spec: LayerSpec) -> str | None:
        taken = [t for t in spec.types if any(t in other.types for other in self._specs.values())]
        if spec.kind in self._specs or taken:
            return f"costmap layer {spec.kind} ({', '.join(taken) or spec.kind}) is registered already"
        return None

    @property
    def specs(self) -> tuple[LayerSpec, ...]:
        return tuple(self._specs.values())

    def spec(self, kind: str) -> LayerSpec:
        return self._specs[kind]

    def kind(self, plugin_type: str, plugin_name: str) -> str:
        """The kind a type string selects; ParameterError naming the supported types for any other."""
        for spec in self._specs.values():
            if plugin_type in spec.types:
                return spec.kind
        supported = ", ".join(t for spec in self._specs.values() for t in spec.types)
        raise ParameterError(f"costmap plugin {plugin_name!r} has unsupported type {plugin_type!r}; "
                             f"supported types: {supported}")

    def create(self, plugin_name: str, kind: str, params: dict) -> Layer:
        """A new layer from its resolved parameter dict (see params.py)."""
        return self._specs[kind].layer(plugin_name, **params)


LAYERS = LayerRegistry([
    builtin(StaticLayer, StaticLayerParams, ("map_topic", "unknown_cost_value", "lethal_cost_threshold",
                                             "track_unknown_space")),
    builtin(ObstacleLayer, ObstacleLayerParams, ("max_obstacle_height", "raytrace_range", "obstacle_range",
                                                 "track_unknown_space")),
    builtin(InflationLayer, InflationLayerParams, ("cost_scaling_factor", "inflation_radius")),
])
