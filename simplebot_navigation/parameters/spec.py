"""Declared parameters: one field spec, one validation, one rule for unknown keys.

Every configuration class is a dataclass whose parameter fields are made with ``param()``; the
spec travels in the field's metadata, so defaults are written once. A large class may group its
parameters into sections (``section()``, as teb_config.h groups TebConfig's into structs): the names
stay flat, so parsing, listing and setting by name see one namespace, and only attribute access goes
through the section (``cfg.robot.max_vel_x``). ``load`` turns one ROS 1 namespace (a dict) into
checked values plus warnings for the ROS shell to log. No rclpy here.

The rules, the same for every namespace:
- a value of the wrong type, a NaN or an infinity where a number is expected, or a value out of
  range raises ParameterError naming ``namespace/key`` and the value;
- an unknown key is ignored, as ROS would, with one warning naming it and the closest known key;
- a key whose feature is not implemented here is accepted with one warning naming it.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import enum
import functools
import math
from dataclasses import dataclass
from typing import Any

_META = "simplebot_navigation.parameter"
_SECTION = "simplebot_navigation.parameter_section"


class ParameterError(ValueError):
    """A parameter value that cannot be used; the message names where it was set and the value."""


class Status(enum.Enum):
    IMPLEMENTED = "implemented"
    NOT_IMPLEMENTED = "accepted, not implemented"
    NOT_FOR_THIS_ROBOT = "accepted, not for a differential-drive robot"


@dataclass(frozen=True)
class Param:
    """One parameter: what it is, what it may be, and whether setting it does anything here."""
    kind: type | tuple            # bool, int, float, str, list or dict (or a tuple of them)
    default: Any
    unit: str                     # "m", "m/s", "s", "Hz", "" for flags and names, ...
    doc: str
    low: float | None = None      # lower bound, inclusive unless low_open
    low_open: bool = False
    high: float | None = None     # upper bound, inclusive
    status: Status = Status.IMPLEMENTED
    reason: str = ""              # why it is not implemented, or what is done instead
    dynamic: bool = True          # False: a change needs a restart (frames, plugin lists, model types)
    rounds: bool = False          # int read from a double by rounding half up, as ROS 1 getParam does
    name: str = ""

    @property
    def implemented(self) -> bool:
        return self.status is Status.IMPLEMENTED

    def range_text(self) -> str:
        lower = "" if self.low is None else f"{'>' if self.low_open else '>='} {self.low:g}"
        if self.high is None:
            return lower
        if self.low is None:
            return f"<= {self.high:g}"
        return f"in [{self.low:g}, {self.high:g}]" if not self.low_open else f"in ({self.low:g}, {self.high:g}]"

    def describe(self) -> str:
        """One line: doc, unit, range and status (for descriptors and --print-params)."""
        parts = [self.doc]
        if self.unit:
            parts.append(f"[{self.unit}]")
        if self.range_text():
            parts.append(f"({self.range_text()})")
        if not self.implemented:
            parts.append(f"-- {self.status.value}: {self.reason}")
        if not self.dynamic:
            parts.append("-- requires restart")
        return " ".join(parts)

    def check(self, value: Any, where: str) -> Any:
        """The value converted to this parameter's type, or ParameterError naming ``where``."""
        value = _convert(self, value, where)
        if self.kind in (int, float):
            below = self.low is not None and (value <= self.low if self.low_open else value < self.low)
            above = self.high is not None and value > self.high
            if below or above:
                raise ParameterError(f"{where}: must be {self.range_text()}, got {value!r}")
        return value

    def warning(self, where: str) -> str:
        """The one warning logged when a not-implemented parameter is set."""
        if self.status is Status.NOT_FOR_THIS_ROBOT:
            return f"{where} has no effect: this robot is a differential drive ({self.reason})"
        return f"{where} is accepted but not implemented, so it has no effect: {self.reason}"


_KIND_WORDS = {bool: "true or false", int: "an integer", float: "a number", str: "a string",
               list: "a list", dict: "a namespace (mapping)"}


def _convert(spec: Param, value: Any, where: str) -> Any:
    def bad(extra: str = "") -> ParameterError:
        kinds = spec.kind if isinstance(spec.kind, tuple) else (spec.kind,)
        words = " or ".join(_KIND_WORDS[kind] for kind in kinds)
        return ParameterError(f"{where}: expected {words}{extra}, got {value!r}")

    if spec.kind is bool:
        if not isinstance(value, bool):
            raise bad()
        return value
    if spec.kind in (int, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise bad()
        if not math.isfinite(value):
            raise bad(" (finite)")
        if spec.kind is float:
            return float(value)
        if isinstance(value, float):
            if spec.rounds:
                return int(math.floor(value) if math.fmod(value, 1.0) < 0.5 else math.ceil(value))
            if not value.is_integer():
                raise bad()
        return int(value)
    if not isinstance(value, spec.kind):
        raise bad()
    return copy.deepcopy(value)


def param(default: Any, unit: str, doc: str, *, ge: float | None = None, gt: float | None = None,
          le: float | None = None, not_implemented: str = "", not_for_this_robot: str = "",
          restart: bool = False, rounds: bool = False, kind: type | None = None) -> Any:
    """A dataclass field that is a parameter. ``not_implemented`` / ``not_for_this_robot`` give the reason
    setting it has no effect here; ``restart`` marks what cannot change while running."""
    status, reason = Status.IMPLEMENTED, ""
    if not_implemented:
        status, reason = Status.NOT_IMPLEMENTED, not_implemented
    elif not_for_this_robot:
        status, reason = Status.NOT_FOR_THIS_ROBOT, not_for_this_robot
    kind = kind or type(default)     # a tuple of types where several forms are accepted
    spec = Param(kind, default, unit, doc, low=gt if gt is not None else ge, low_open=gt is not None, high=le,
                 status=status, reason=reason, dynamic=not restart, rounds=rounds)
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda: copy.deepcopy(default), metadata={_META: spec})
    return dataclasses.field(default=default, metadata={_META: spec})


def section(cls) -> Any:
    """A dataclass field holding the section ``cls``, a dataclass of parameters (or of further sections)."""
    return dataclasses.field(default_factory=cls, metadata={_SECTION: cls})


@functools.cache
def _layout(cls) -> dict[str, tuple[tuple[str, ...], Param]]:
    """Every parameter of ``cls`` by its flat name: (the section attributes leading to it, its spec)."""
    layout: dict[str, tuple[tuple[str, ...], Param]] = {}

    def add(name: str, path: tuple[str, ...], spec: Param) -> None:
        if name in layout:
            raise TypeError(f"{cls.__name__}: parameter {name!r} is declared twice (names are flat across sections)")
        layout[name] = (path, spec)

    for f in dataclasses.fields(cls):
        if _SECTION in f.metadata:
            for name, (path, spec) in _layout(f.metadata[_SECTION]).items():
                add(name, (f.name, *path), spec)
        elif _META in f.metadata:
            add(f.name, (), dataclasses.replace(f.metadata[_META], name=f.name))
    return layout


@functools.cache
def fields_of(cls) -> dict[str, Param]:
    """The parameters of a configuration dataclass, sections included, by name, in declaration order."""
    return {name: spec for name, (_, spec) in _layout(cls).items()}


def _owner(config: Any, name: str) -> Any:
    """The object (``config`` or one of its sections) whose attribute ``name`` is."""
    for part in _layout(type(config))[name][0]:
        config = getattr(config, part)
    return config


def value_of(config: Any, name: str) -> Any:
    """The value of the parameter ``name`` (its flat name) in a configuration."""
    return getattr(_owner(config, name), name)


def set_value(config: Any, name: str, value: Any) -> None:
    """Set the parameter ``name`` (its flat name) in a configuration, in the section that holds it."""
    setattr(_owner(config, name), name, value)


def values_of(config: Any) -> dict[str, Any]:
    """Every parameter of a configuration by its flat name, in declaration order."""
    return {name: value_of(config, name) for name in _layout(type(config))}


#: where the ROS 2 form of a {name, type} list keeps each entry's type (``<name>.plugin``)
PLUGIN_TYPE_KEY = "plugin"


def unknown_key_warning(where: str, key: Any, known) -> str:
    close = difflib.get_close_matches(str(key), [str(k) for k in known], n=1, cutoff=0.6)
    hint = f" (did you mean '{close[0]}'?)" if close else ""
    return f"{where}: unknown parameter '{key}' ignored{hint}"


def namespace(values: Any, where: str) -> dict:
    """``values`` if it is a namespace, else ParameterError."""
    if not isinstance(values, dict):
        raise ParameterError(f"{where}: expected a namespace (mapping), got {values!r}")
    return values


def load(specs: dict[str, Param], given: Any, where: str, also_known=()) -> tuple[dict, list[str]]:
    """Check every key of one namespace against its specs: (checked values, warnings).

    ``also_known`` are keys another part of the configuration reads (sub-namespaces, keys found by
    searchParam); they are neither checked nor reported here."""
    values, warnings = {}, []
    for key, value in namespace(given, where).items():
        spec = specs.get(key)
        if spec is None:
            if key not in also_known:
                warnings.append(unknown_key_warning(where, key, list(specs) + list(also_known)))
            continue
        values[key] = spec.check(value, f"{where}/{key}")
        if not spec.implemented:
            warnings.append(spec.warning(f"{where}/{key}"))
    return values, warnings


def build(cls, given: Any, where: str, also_known=()) -> tuple[Any, list[str]]:
    """An instance of the configuration dataclass ``cls`` from one namespace: (config, warnings)."""
    values, warnings = load(fields_of(cls), given if given is not None else {}, where, also_known)
    return _construct(cls, values), warnings


def _construct(cls, values: dict[str, Any]) -> Any:
    """``cls`` with the given values (by flat name) in its fields and sections, the defaults elsewhere."""
    kwargs = {}
    for f in dataclasses.fields(cls):
        if _SECTION in f.metadata:
            kwargs[f.name] = _construct(f.metadata[_SECTION], values)
        elif f.name in values:
            kwargs[f.name] = values[f.name]
    return cls(**kwargs)
