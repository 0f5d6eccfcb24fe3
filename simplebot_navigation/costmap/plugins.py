"""Costmap layers by plugin type (ROS 1 ``costmap_2d::`` and Nav2 ``nav2_costmap_2d::`` names): the registry and
the registration each layer's module declares.

A layer is a subclass of ``Layer`` (costmap/layer.py documents every hook); one that reads a map or sensors
also satisfies ``MapLayer`` or ``SensorLayer`` there, and the ROS shell feeds it. Its module holds its
``LayerSpec`` (a sensor layer's is a ``SensorLayerSpec``, costmap/observation.py), named by a
``simplebot_navigation.costmap_layers`` entry point in pyproject.toml. The spec's methods are the layer's
parameter hooks: how its namespace resolves, which parameters it declares, which it takes while running and
how it writes them back; everything that handles layer parameters (params.py, costmap_core.py, the ROS shell)
calls them for every layer alike. docs/plugins.md shows how to add one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from simplebot_navigation.costmap.layer import Layer
from simplebot_navigation.parameters import PLUGIN_TYPE_KEY, Param, ParameterError, fields_of, load
from simplebot_navigation.pluginlib import Registry

#: the prefixes both ROS generations give the built-in layers' types
_NAMESPACES = ("costmap_2d::", "nav2_costmap_2d::")

#: what LayerContext.search finds when no namespace has the key
MISSING = object()


@dataclass
class LayerContext:
    """What resolving a layer's namespace may read beyond it: the costmap's configuration resolved so far
    (a CostmapConfig: frames, size, track_unknown_space, ...) and the namespaces searchParam looks in, as
    (values, path) pairs, nearest first (the costmap's own, then its parents')."""
    costmap: Any
    chain: list[tuple[dict, str]]

    def search(self, key: str, nearer=()) -> tuple[Any, str]:
        """searchParam: the value of ``key`` in the nearest namespace that has it, ``nearer`` ones (a layer's,
        a source's) first, and where it was found; (MISSING, key) when none has it."""
        for values, path in [*nearer, *self.chain]:
            if key in values:
                return values[key], f"{path}/{key}"
        return MISSING, key

    def searched(self, key: str, spec: Param, nearer=()):
        """The value searchParam finds for ``key``, checked against ``spec``; its default when none is set."""
        value, path = self.search(key, nearer)
        return spec.default if value is MISSING else spec.check(value, path)


@dataclass(frozen=True)
class LayerSpec:
    """One layer type's registration, and its parameter hooks for a layer without sub-namespaces."""
    kind: str                          # the class name, as the parameter tree and the logs call it
    types: tuple[str, ...]             # plugin type strings that select it
    layer: type[Layer]                 # built as layer(name, **params), params as resolve() gives them
    params: type                       # the parameter dataclass of its namespace
    #: costmap-level keys copied into the layer's namespace when a plugin list is given (costmap_2d's rule)
    parent_keys: tuple[str, ...] = ()
    #: fields whose default is the costmap's value of the same name (an obstacle layer's track_unknown_space)
    costmap_defaults: tuple[str, ...] = ()

    #: keys the layer's sub-namespaces search upwards (searchParam), so enclosing namespaces may hold them
    searched_keys: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def builtin(cls, layer: type[Layer], params: type, parent_keys: tuple[str, ...] = (), **hooks) -> LayerSpec:
        """A spec for a layer under both costmap_2d's and Nav2's names."""
        return cls(layer.__name__, tuple(ns + layer.__name__ for ns in _NAMESPACES), layer, params, parent_keys,
                   **hooks)

    def keys(self) -> dict[str, Param]:
        """Every key its namespace reads, by bare name (what a parent key copied into it is checked against)."""
        return dict(fields_of(self.params))

    def resolve(self, tree: dict, path: str, context: LayerContext) -> tuple[dict, list[str]]:
        """The keyword arguments the layer is built with, from its namespace ``tree`` (ROS 1 form, at ``path``),
        and the warnings to log; ParameterError naming the key for a bad value."""
        return self.load_own(tree, path, context)

    def load_own(self, tree: dict, path: str, context: LayerContext, also_known=()) -> tuple[dict, list[str]]:
        """The fields of ``params``: their defaults, then the costmap's for ``costmap_defaults``, then the given
        values; other keys of the namespace are warned about unless ``also_known``."""
        specs = fields_of(self.params)
        given, warnings = load(specs, tree, path, also_known=[PLUGIN_TYPE_KEY, *also_known])
        defaults = {key: spec.default for key, spec in specs.items()}
        inherited = {key: getattr(context.costmap, key) for key in self.costmap_defaults}
        return {**defaults, **inherited, **given}, warnings

    def parameter_specs(self, params: dict) -> dict[str, Param]:
        """Every parameter below the layer's namespace by ROS 2 name relative to it, for a layer resolved to
        ``params``."""
        return dict(fields_of(self.params))

    def live_params(self, params: dict) -> dict:
        """What the layer's ``reconfigure`` gets from resolved ``params``: those that may change while running."""
        specs = fields_of(self.params)
        return {key: value for key, value in params.items() if key in specs and specs[key].dynamic}

    def parameter_tree(self, params: dict) -> dict:
        """Resolved ``params`` in the ROS 1 form of the layer's namespace (what the node declares)."""
        return dict(params)


class LayerRegistry(Registry[LayerSpec]):
    """Layers by kind; a type string selects one kind only."""

    spec_type = LayerSpec

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


LAYERS = LayerRegistry("simplebot_navigation.costmap_layers")
