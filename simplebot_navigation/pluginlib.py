"""Plugin types registered by name, as ROS 1's pluginlib does: each plugin's own module declares it.

A plugin's module holds its registration (a spec: type names, parameter class, implementation) and one line
of pyproject.toml's ``[project.entry-points."<group>"]`` names that object, as a pluginlib XML file names a
class. A registry reads its group the first time it is asked anything (once, by entry-point name, so the
order of the types does not depend on the installer); an application adds its own plugins with ``register``
in the same process, or with entry points of its own package. docs/plugins.md shows both.
"""

from __future__ import annotations

import contextlib
import importlib
import threading
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Any, Callable, Generic, Iterator, TypeVar

Spec = TypeVar("Spec")


class EntryPointError(RuntimeError):
    """An entry point that does not give a spec of its group: the message names both and says why."""


class Registry(Generic[Spec]):
    """Specs by their key, from the entry points of ``group`` and from ``register``; a second registration
    under a key already taken is refused."""

    #: what every entry point of the group must name
    spec_type: type = object

    def __init__(self, group: str):
        self.group = group
        self._registered: dict[str, Spec] = {}
        self._lock = threading.RLock()
        self._loaded = False
        self._loading = False

    @property
    def _specs(self) -> dict[str, Spec]:
        """Every spec by key, the group's entry points read first (once)."""
        if not self._loaded:
            self._load_entry_points()
        return self._registered

    def _load_entry_points(self) -> None:
        with self._lock:
            if self._loaded or self._loading:      # loaded by another thread, or registering what was loaded
                return
            points = sorted(entry_points(group=self.group), key=lambda point: point.name)
            if not points:
                raise EntryPointError(f"no entry points in group {self.group}: the package that declares them is "
                                      "not installed (pip install -e . in a checkout)")
            self._loading = True
            before = dict(self._registered)
            try:
                for point in points:
                    spec = self._spec_of(point)
                    try:
                        self.register(spec)
                    except ValueError as err:
                        raise EntryPointError(self._describe(point, str(err))) from None
                self._loaded = True
            except EntryPointError:
                self._registered = before
                raise
            finally:
                self._loading = False

    def _spec_of(self, point: EntryPoint) -> Spec:
        try:
            spec = point.load()
        except Exception as err:        # whatever the plugin's module raises while it is imported
            raise EntryPointError(self._describe(point, f"{type(err).__name__}: {err}")) from None
        if not isinstance(spec, self.spec_type):
            raise EntryPointError(self._describe(point, f"it names a {type(spec).__name__}, not a "
                                                        f"{self.spec_type.__name__}"))
        return spec

    def _describe(self, point: EntryPoint, why: str) -> str:
        package = f" of package {point.dist.name}" if point.dist is not None else ""
        return f"entry point {point.name} = {point.value!r}{package} in group {self.group}: {why}"

    def key(self, spec: Spec) -> str:
        raise NotImplementedError

    def conflict(self, spec: Spec) -> str | None:
        """Why ``spec`` cannot be registered, or None."""
        return f"{self.key(spec)} is registered already" if self.key(spec) in self._specs else None

    def register(self, spec: Spec) -> Spec:
        problem = self.conflict(spec)
        if problem:
            raise ValueError(problem)
        self._registered[self.key(spec)] = spec
        return spec

    def unregister(self, key: str) -> None:
        self._specs.pop(key, None)

    @contextlib.contextmanager
    def registered(self, spec: Spec) -> Iterator[Spec]:
        """Known inside the block only (for a test's own plugin)."""
        self.register(spec)
        try:
            yield spec
        finally:
            self.unregister(self.key(spec))


@dataclass(frozen=True)
class PluginSpec:
    """One move_base plugin type: its implementation and what its parameter namespace holds."""
    type: str
    #: the factory move_base calls; "package.module:attribute" text when importing it needs rclpy (a ROS
    #: wrapper), so that the registration stays importable without ROS: the ROS node loads it
    implementation: Callable | str
    params: type | None = None          # the parameter dataclass of its namespace (None: it has none)
    #: builds its configuration from its namespace (ROS 1 form, None when absent): (config, warnings);
    #: planners only, the ROS wrapper builds its own from the same namespace
    config: Callable[[dict | None], tuple[Any, list[str]]] | None = None
    #: a local planner's values of its namespace that follow move_base's one speed setting (max_speed, m/s) and
    #: the robot's drive (its wheel separation in m, None when the launch does not know the robot), by name within
    #: the namespace (move_base/speed_profile.py); None: none follow them
    speed_parameters: Callable[[float, float | None], dict[str, float]] | None = None

    def load(self) -> Any:
        if not isinstance(self.implementation, str):
            return self.implementation
        module, _, attribute = self.implementation.partition(":")
        found = importlib.import_module(module)
        for part in attribute.split("."):
            found = getattr(found, part)
        return found
