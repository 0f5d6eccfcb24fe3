"""Layer classes by plugin type string (ROS 1 `costmap_2d::` and Nav2 `nav2_costmap_2d::` names)."""

from __future__ import annotations

from .inflation_layer import InflationLayer
from .obstacle_layer import ObstacleLayer
from .static_layer import StaticLayer

LAYER_CLASSES = {"ObstacleLayer": ObstacleLayer, "InflationLayer": InflationLayer, "StaticLayer": StaticLayer}
_NAMESPACES = ("costmap_2d::", "nav2_costmap_2d::")


def layer_kind(plugin_type: str, plugin_name: str) -> str:
    """'ObstacleLayer' / 'InflationLayer' / 'StaticLayer' for a supported type string, else ValueError."""
    if isinstance(plugin_type, str):
        for namespace in _NAMESPACES:
            if plugin_type.startswith(namespace) and plugin_type[len(namespace):] in LAYER_CLASSES:
                return plugin_type[len(namespace):]
    supported = ", ".join(f"{ns}{kind}" for ns in _NAMESPACES for kind in LAYER_CLASSES)
    raise ValueError(f"costmap plugin {plugin_name!r} has unsupported type {plugin_type!r}; "
                     f"supported types: {supported}")


def create_layer(plugin_name: str, plugin_type: str, params: dict):
    """A new layer from its resolved parameter dict (see params.py)."""
    return LAYER_CLASSES[layer_kind(plugin_type, plugin_name)](plugin_name, **params)
