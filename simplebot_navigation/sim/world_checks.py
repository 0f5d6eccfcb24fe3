"""The world loader's checks: types and ranges of every entry, each error naming the file, the entry
and the key (``lab.yaml: moving[3].radius: ...``)."""

from __future__ import annotations

import math
from typing import Any

from simplebot_navigation.sim.moving import DEFAULT_HEIGHT, MovingObstacle, MovingObstacleError


class WorldValidator:
    """Type and range checks that name the file and the entry in every message."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, where: str, problem: str):
        raise ValueError(f"{self.source}: {where}: {problem}")

    def entries(self, data: dict, key: str, required: tuple, optional: tuple):
        items = data.get(key) or []
        if not isinstance(items, list):
            self.fail(key, f"expected a list, got {type(items).__name__}")
        allowed = set(required) | set(optional) | {"name"}
        for i, entry in enumerate(items):
            where = f"{key}[{i}]"
            if not isinstance(entry, dict):
                self.fail(where, f"expected a mapping, got {type(entry).__name__} {entry!r}")
            missing = [k for k in required if k not in entry]
            if missing:
                self.fail(where, f"missing key {missing[0]!r}")
            unknown = sorted(set(entry) - allowed, key=str)
            if unknown:
                self.fail(where, f"unknown key {unknown[0]!r} (expected {', '.join(sorted(allowed))})")
            yield where, entry

    def number(self, entry: dict, where: str, key: str, default: float | None = None) -> float:
        value = entry.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(f"{where}.{key}", f"expected a number, got {type(value).__name__} {value!r}")
        if not math.isfinite(value):
            self.fail(f"{where}.{key}", f"expected a finite number, got {value}")
        return float(value)

    def positive(self, entry: dict, where: str, key: str, default: float | None = None) -> float:
        value = self.number(entry, where, key, default)
        if value < 0:
            self.fail(f"{where}.{key}", f"negative {key} {value}")
        if value == 0:
            self.fail(f"{where}.{key}", f"{key} must be positive, got 0")
        return value

    def vec2(self, entry: dict, where: str, key: str) -> tuple[float, float]:
        value = entry[key]
        if not isinstance(value, list) or len(value) != 2:
            self.fail(f"{where}.{key}", f"expected [x, y], got {value!r}")
        pair = {"x": value[0], "y": value[1]}
        return self.number(pair, f"{where}.{key}", "x"), self.number(pair, f"{where}.{key}", "y")

    def size2(self, entry: dict, where: str, key: str) -> tuple[float, float]:
        sx, sy = self.vec2(entry, where, key)
        for value in (sx, sy):
            if value < 0:
                self.fail(f"{where}.{key}", f"negative size {value}")
            if value == 0:
                self.fail(f"{where}.{key}", f"size must be positive, got {[sx, sy]}")
        return sx, sy

    def label(self, entry: dict, where: str) -> str | None:
        name = entry.get("name")
        if name is not None and not isinstance(name, str):
            self.fail(f"{where}.name", f"expected a string, got {type(name).__name__} {name!r}")
        return name

    def start_list(self, items: Any) -> list[tuple[float, float, float]]:
        """``starts: [[x, y, yaw], ...]`` as (x, y, yaw) each; yaw may be left out."""
        if not isinstance(items, list):
            self.fail("starts", f"expected a list of [x, y, yaw], got {type(items).__name__}")
        poses = []
        for i, item in enumerate(items):
            if not isinstance(item, list) or len(item) not in (2, 3):
                self.fail(f"starts[{i}]", f"expected [x, y, yaw], got {item!r}")
            pose = dict(zip(("x", "y", "yaw"), item))
            poses.append(tuple(self.number(pose, f"starts[{i}]", key, 0.0) for key in ("x", "y", "yaw")))
        return poses

    def pose(self, entry: Any, where: str) -> tuple[float, float, float, str | None]:
        """``{x, y, yaw, name}`` as (x, y, yaw, name)."""
        if not isinstance(entry, dict):
            self.fail(where, f"expected a mapping {{x, y, yaw}}, got {type(entry).__name__} {entry!r}")
        unknown = sorted(set(entry) - {"x", "y", "yaw", "name"}, key=str)
        if unknown:
            self.fail(where, f"unknown key {unknown[0]!r} (expected x, y, yaw, name)")
        for key in ("x", "y"):
            if key not in entry:
                self.fail(where, f"missing key {key!r}")
        return (self.number(entry, where, "x"), self.number(entry, where, "y"),
                self.number(entry, where, "yaw", 0.0), self.label(entry, where))

    def moving(self, entry: dict, where: str) -> MovingObstacle:
        """One ``moving:`` entry; the value rules (times increasing, sizes positive) are MovingObstacle's."""
        shape = self.text(entry, where, "shape")
        needed, other = ("radius", "size") if shape == "cylinder" else ("size", "radius")
        if shape in ("cylinder", "box"):
            if needed not in entry:
                self.fail(where, f"missing key {needed!r} (a {shape} needs it)")
            if other in entry:
                self.fail(f"{where}.{other}", f"a {shape} has {needed}, not {other}")
        frames = entry["keyframes"]
        if not isinstance(frames, list):
            self.fail(f"{where}.keyframes", f"expected a list of [t, x, y], got {type(frames).__name__}")
        keyframes = []
        for i, frame in enumerate(frames):
            if not isinstance(frame, list) or len(frame) != 3:
                self.fail(f"{where}.keyframes[{i}]", f"expected [t, x, y], got {frame!r}")
            values = dict(zip("txy", frame))
            keyframes.append(tuple(self.number(values, f"{where}.keyframes[{i}]", key) for key in "txy"))
        loop = entry.get("loop", False)
        if not isinstance(loop, bool):
            self.fail(f"{where}.loop", f"expected true or false, got {loop!r}")
        try:
            return MovingObstacle(
                shape, tuple(keyframes), radius=self.number(entry, where, "radius", 0.0),
                size=self.vec2(entry, where, "size") if "size" in entry else (0.0, 0.0),
                height=self.number(entry, where, "height", DEFAULT_HEIGHT),
                interpolation=self.text(entry, where, "interpolation", "linear"), loop=loop,
                phase=self.number(entry, where, "phase", 0.0), name=self.label(entry, where))
        except MovingObstacleError as err:
            self.fail(f"{where}.{err.key}", err.problem)

    def text(self, entry: dict, where: str, key: str, default: str | None = None) -> str:
        value = entry.get(key, default)
        if not isinstance(value, str):
            self.fail(f"{where}.{key}", f"expected a string, got {type(value).__name__} {value!r}")
        return value
