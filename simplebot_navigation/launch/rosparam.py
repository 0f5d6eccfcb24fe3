"""A ROS 1 parameter server in miniature, and its mapping to ROS 2 parameter overrides.

roslaunch flattens a loaded YAML dict into leaf parameters, so loading a second
file into the same namespace merges with (and overrides leaves of) the first;
lists are leaves. The mapping to ROS 2 parameter names and types is in parameters/ros2.py.
"""

from __future__ import annotations

from typing import Any

import yaml

from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.parameters.overrides import set_in_tree
from simplebot_navigation.parameters.ros2 import from_ros2_overrides, to_ros2_overrides

__all__ = ["ParamError", "ParamServer", "from_ros2_overrides", "join_ns", "load_yaml_file", "to_ros2_overrides"]


#: a parameter file or value that cannot be used; the message names the file and key
ParamError = ParameterError


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
        set_in_tree(self.tree, "/".join(parts), value, separator="/")

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
