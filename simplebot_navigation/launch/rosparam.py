"""A ROS 1 parameter server in miniature, and its mapping to ROS 2 parameter overrides.

roslaunch flattens a loaded YAML dict into leaf parameters, so loading a second
file into the same namespace merges with (and overrides leaves of) the first;
lists are leaves. DESIGN §4 gives the mapping to ROS 2 parameter names and types.
"""

from __future__ import annotations

import math
from typing import Any

import yaml


class ParamError(ValueError):
    """A parameter file or value that cannot be used; the message names the file and key."""


def join_ns(*parts: str) -> str:
    """roslaunch's ns_join for absolute names: '/', 'move_base', 'global_costmap/' -> '/move_base/global_costmap'."""
    out = ""
    for part in parts:
        if not part:
            continue
        if part.startswith("/"):
            out = part.rstrip("/")
        else:
            out = f"{out}/{part.strip('/')}"
    return out or "/"


def _check_value(value: Any, where: str) -> None:
    if value is None:
        raise ParamError(f"{where}: empty value (null) is not a valid parameter")
    if isinstance(value, bool) or isinstance(value, (int, str)):
        return
    if isinstance(value, float):
        return
    if isinstance(value, list):
        for i, item in enumerate(value):
            _check_value(item, f"{where}[{i}]")
        return
    if isinstance(value, dict):
        for key, item in value.items():
            if not isinstance(key, str) or not key:
                raise ParamError(f"{where}: key {key!r} is a {type(key).__name__}, parameter names must be strings")
            _check_value(item, f"{where}/{key}")
        return
    raise ParamError(f"{where}: value {value!r} of YAML type {type(value).__name__} is not a parameter type "
                     "(use bool, int, float, string, list or dict)")


def load_yaml_file(path: str) -> dict:
    """Read a rosparam YAML file; every failure names the file (and the line, or the key)."""
    try:
        with open(path, encoding="utf-8") as handle:
            text = handle.read()
    except OSError as err:
        raise ParamError(f"{path}: cannot read parameter file ({err.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(err, "problem", None) or str(err)
        raise ParamError(f"{path}: malformed YAML{where}: {problem}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ParamError(f"{path}: top level must be a mapping of parameter names, got {type(data).__name__}")
    _check_value(data, path + ":")
    return data


class ParamServer:
    """The ROS 1 parameter tree: absolute names like '/move_base/global_costmap/width'."""

    def __init__(self) -> None:
        self.tree: dict = {}

    def set(self, name: str, value: Any) -> None:
        """Set a parameter; a dict value is flattened into leaves, as roslaunch does."""
        if isinstance(value, dict):
            for key, item in value.items():
                self.set(join_ns(name, key), item)
            return
        parts = [p for p in name.split("/") if p]
        if not parts:
            raise ParamError("cannot set a non-dict value on the root namespace")
        node = self.tree
        for part in parts[:-1]:
            child = node.get(part)
            if not isinstance(child, dict):
                child = node[part] = {}
            node = child
        node[parts[-1]] = value

    def get(self, name: str, default: Any = KeyError) -> Any:
        node: Any = self.tree
        for part in (p for p in name.split("/") if p):
            if not isinstance(node, dict) or part not in node:
                if default is KeyError:
                    raise KeyError(name)
                return default
            node = node[part]
        return node

    def load(self, path: str, ns: str) -> None:
        """``<rosparam command="load" file=path ns=ns>`` relative to an absolute namespace."""
        self.set(ns, load_yaml_file(path))

    def items(self, prefix: str = "/"):
        """All leaf parameters under prefix as (absolute name, value), sorted."""
        def walk(node, path):
            for key in sorted(node):
                item = node[key]
                if isinstance(item, dict):
                    yield from walk(item, f"{path}/{key}")
                else:
                    yield f"{path}/{key}", item
        sub = self.get(prefix, {})
        base = prefix.rstrip("/")
        return list(walk(sub, base)) if isinstance(sub, dict) else [(prefix, sub)]


def _array_value(key: str, values: list) -> list:
    kinds = {type(v) for v in values}
    if kinds == {bool}:
        return values
    if kinds <= {int, float} and bool not in kinds:
        if kinds == {int}:
            return values
        return [float(v) for v in values]
    if kinds == {str}:
        return values
    raise ParamError(f"{key}: a list must hold values of one type (bool, number or string), got "
                     f"{sorted(k.__name__ for k in kinds)}")


def _format_nested_list(value: list) -> str:
    def fmt(item):
        if isinstance(item, list):
            return "[" + ", ".join(fmt(i) for i in item) + "]"
        return repr(item) if isinstance(item, str) else str(item)
    return fmt(value)


def to_ros2_overrides(tree: dict, where: str = "") -> dict[str, Any]:
    """Map a ROS 1 subtree to flat ROS 2 parameters (DESIGN §4)."""
    out: dict[str, Any] = {}

    def put(name: str, value: Any) -> None:
        if isinstance(value, float) and not math.isfinite(value):
            raise ParamError(f"{where}{name}: {value} is not a finite number")
        out[name] = value

    def walk(node: dict, prefix: str) -> None:
        for key, value in node.items():
            name = f"{prefix}{key}"
            if isinstance(value, dict):
                walk(value, name + ".")
            elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
                names = []
                for i, entry in enumerate(value):
                    if "name" not in entry or "type" not in entry:
                        raise ParamError(f"{where}{name}[{i}]: plugin entries need 'name' and 'type', got {entry}")
                    names.append(str(entry["name"]))
                    for sub_key, sub_value in entry.items():
                        if sub_key == "name":
                            continue
                        put(f"{prefix}{entry['name']}.{'plugin' if sub_key == 'type' else sub_key}", sub_value)
                put(name, names)
            elif isinstance(value, list) and (not value or any(isinstance(v, (list, dict)) for v in value)):
                put(name, _format_nested_list(value))
            elif isinstance(value, list):
                put(name, _array_value(f"{where}{name}", value))
            else:
                put(name, value)

    walk(tree, "")
    return out


def from_ros2_overrides(params: dict[str, Any]) -> dict:
    """Rebuild the ROS 1 tree a node was given: dotted names nest, plugin lists come back as [{name, type}]."""
    tree: dict = {}
    for name, value in params.items():
        node = tree
        parts = name.split(".")
        for part in parts[:-1]:
            child = node.get(part)
            if not isinstance(child, dict):
                child = node[part] = {}
            node = child
        node[parts[-1]] = list(value) if isinstance(value, (list, tuple)) else value

    def restore(node: dict) -> None:
        for key, value in list(node.items()):
            if isinstance(value, dict):
                restore(value)
            elif (isinstance(value, list) and value and all(isinstance(v, str) for v in value)
                  and all(isinstance(node.get(v), dict) and "plugin" in node[v] for v in value)):
                node[key] = [{"name": v, "type": node[v]["plugin"]} for v in value]
    restore(tree)
    return tree
