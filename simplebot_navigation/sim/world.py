"""Simulator worlds: the YAML world format, its strict loader, and geometry queries on it.

World file shape (README, "World format", documents every key)::

    name: lab
    walls:     [{from: [x1, y1], to: [x2, y2], thickness: 0.1, height: 1.0}]
    boxes:     [{center: [x, y], size: [sx, sy], yaw: 0.0, height: 1.0}]
    cylinders: [{center: [x, y], radius: 0.075, height: 1.0}]
    moving:    [{shape: cylinder, radius: 0.3, keyframes: [[t, x, y], ...], interpolation: linear,
                 loop: false, phase: 0.0, height: 1.0}]      # or shape: box with size: [sx, sy]
    start: {x: 0.0, y: 0.0, yaw: 0.0}
    goals: [{x: 5.0, y: 2.0, yaw: 0.0, name: kitchen}]
    starts: [[x, y, yaw], ...]    # optional: where robot1, robot2, ... start when there are several

A wall is the box of its thickness around the segment from -> to and ends exactly at the end points,
so the gap between two collinear walls is the clear width of the door between them. Every entry may
carry a ``name`` (a label); any other unknown key in an entry is an error, because a misspelt
``thicknes`` would otherwise silently fall back to the default. An unknown top-level key is ignored
with a warning in ``World.warnings`` (which the simulator node and the scenario runner print); the
metadata generated worlds record (METADATA_KEYS) is kept in ``World.extra``. ``--world
path/to/map.yaml`` (a map_server map) is accepted too, see world_loader and map_import.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Iterator, Mapping

import numpy as np
import yaml

from simplebot_navigation.geometry import inverse_transform_points, transform_points
from simplebot_navigation.sim.moving import DEFAULT_HEIGHT, MovingObstacle
from simplebot_navigation.sim.world_checks import WorldValidator

WORLD_KEYS = ("name", "walls", "boxes", "cylinders", "moving", "start", "goals", "starts")
#: what the generators record about a world (world_gen.py, map_import.py): kept in World.extra, no warning
METADATA_KEYS = ("seed", "min_gap", "robot_width", "doors", "occupancy", "field", "min_passage", "cspace", "map",
                 "level", "people", "head_on", "reference_path")
#: what a world may ask of the scenario runner (seconds per goal, metres from the goal that count as
#: arrival): positive numbers, kept in World.extra
RUN_KEYS = ("time_budget", "success_radius")
DEFAULT_THICKNESS = 0.1


@dataclass(frozen=True)
class Pose2D:
    x: float
    y: float
    yaw: float = 0.0
    name: str | None = None


@dataclass(frozen=True)
class Box:
    center: tuple[float, float]
    size: tuple[float, float]
    yaw: float = 0.0
    height: float = DEFAULT_HEIGHT
    name: str | None = None

    def corners(self) -> list[tuple[float, float]]:
        """Its outline in the world frame, counter-clockwise from the (+x, +y) corner."""
        hx, hy = self.size[0] / 2, self.size[1] / 2
        local = np.array([(hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy)])
        return [tuple(p) for p in transform_points((*self.center, self.yaw), local).tolist()]


@dataclass(frozen=True)
class Wall:
    start: tuple[float, float]
    end: tuple[float, float]
    thickness: float = DEFAULT_THICKNESS
    height: float = DEFAULT_HEIGHT
    name: str | None = None

    def as_box(self) -> Box:
        (x1, y1), (x2, y2) = self.start, self.end
        length = math.hypot(x2 - x1, y2 - y1)
        return Box(((x1 + x2) / 2, (y1 + y2) / 2), (length, self.thickness),
                   math.atan2(y2 - y1, x2 - x1), self.height, self.name)


@dataclass(frozen=True)
class Cylinder:
    center: tuple[float, float]
    radius: float
    height: float = DEFAULT_HEIGHT
    name: str | None = None


@dataclass(frozen=True)
class World:
    name: str
    walls: tuple[Wall, ...] = ()
    boxes: tuple[Box, ...] = ()
    cylinders: tuple[Cylinder, ...] = ()
    start: Pose2D = Pose2D(0.0, 0.0, 0.0)
    goals: tuple[Pose2D, ...] = ()
    source: str = "<generated>"
    extra: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    starts: tuple[Pose2D, ...] = ()
    moving: tuple[MovingObstacle, ...] = ()
    #: problems that did not stop the loading (unknown top-level keys), one line each, for the log
    warnings: tuple[str, ...] = field(default=(), compare=False)

    def obstacles(self) -> Iterator[tuple[str, Box | Cylinder]]:
        """Every static solid with the entry label used in messages ("walls[3]"); walls come as boxes.
        Moving obstacles are not among them: C-space analysis and clearance checks are of the static world."""
        for i, wall in enumerate(self.walls):
            yield f"walls[{i}]", wall.as_box()
        for i, box in enumerate(self.boxes):
            yield f"boxes[{i}]", box
        for i, cyl in enumerate(self.cylinders):
            yield f"cylinders[{i}]", cyl

    def goal(self, name: str) -> Pose2D:
        """The goal a scenario asks for by name (e.g. "door_1.5x" in the doors world)."""
        for goal in self.goals:
            if goal.name == name:
                return goal
        names = [g.name for g in self.goals if g.name]
        raise ValueError(f"{self.source}: no goal named {name!r}; goals: {', '.join(names) or 'none named'}")

    def distance(self, points) -> np.ndarray:
        """Distance from each (x, y) point to the nearest obstacle (0 inside one; inf if none)."""
        dist, _ = self._nearest(np.asarray(points, dtype=float).reshape(-1, 2))
        return dist

    def nearest_obstacle(self, x: float, y: float) -> tuple[float, str | None]:
        """(distance, entry label) of the obstacle nearest to a point, for messages and checks."""
        dist, label = self._nearest(np.array([[x, y]], dtype=float))
        return float(dist[0]), label[0]

    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of all obstacles, the start and the goals."""
        xs, ys = [self.start.x], [self.start.y]
        for g in self.goals:
            xs.append(g.x)
            ys.append(g.y)
        for _, shape in self.obstacles():
            cx, cy = shape.center
            if isinstance(shape, Cylinder):
                xs += [cx - shape.radius, cx + shape.radius]
                ys += [cy - shape.radius, cy + shape.radius]
                continue
            c, s = math.cos(shape.yaw), math.sin(shape.yaw)
            hx, hy = shape.size[0] / 2, shape.size[1] / 2
            ex, ey = abs(c * hx) + abs(s * hy), abs(s * hx) + abs(c * hy)
            xs += [cx - ex, cx + ex]
            ys += [cy - ey, cy + ey]
        return min(xs), min(ys), max(xs), max(ys)

    def to_dict(self) -> dict:
        """The world in file shape (what write_world dumps)."""
        def named(d, obj):
            return {**d, "name": obj.name} if obj.name else d

        data = {"name": self.name, **dict(self.extra)}
        data["walls"] = [named({"from": list(w.start), "to": list(w.end), "thickness": w.thickness,
                                "height": w.height}, w) for w in self.walls]
        data["boxes"] = [named({"center": list(b.center), "size": list(b.size), "yaw": b.yaw,
                                "height": b.height}, b) for b in self.boxes]
        data["cylinders"] = [named({"center": list(c.center), "radius": c.radius,
                                    "height": c.height}, c) for c in self.cylinders]
        if self.moving:
            data["moving"] = [named(_moving_dict(m), m) for m in self.moving]
        data["start"] = {"x": self.start.x, "y": self.start.y, "yaw": self.start.yaw}
        data["goals"] = [named({"x": g.x, "y": g.y, "yaw": g.yaw}, g) for g in self.goals]
        if self.starts:
            data["starts"] = [[p.x, p.y, p.yaw] for p in self.starts]
        return data

    def _nearest(self, pts: np.ndarray):
        best = np.full(len(pts), np.inf)
        label = np.full(len(pts), None, dtype=object)
        for name, shape in self.obstacles():
            d = _shape_distance(shape, pts)
            closer = d < best
            best[closer] = d[closer]
            label[closer] = name
        return best, label


def _shape_distance(shape: Box | Cylinder, pts: np.ndarray) -> np.ndarray:
    if isinstance(shape, Cylinder):
        rel = pts - np.asarray(shape.center)
        return np.maximum(np.hypot(rel[:, 0], rel[:, 1]) - shape.radius, 0.0)
    local = np.abs(inverse_transform_points((*shape.center, shape.yaw), pts))
    outside = np.maximum(local - np.asarray(shape.size) / 2, 0.0)
    return np.hypot(outside[:, 0], outside[:, 1])


def world_from_dict(data: Any, source: str = "<generated>", default_name: str = "world") -> World:
    """Validate a parsed world file; ``source`` names it in error messages."""
    v = WorldValidator(source)
    if not isinstance(data, dict):
        v.fail("top level", f"expected a mapping with walls/boxes/cylinders/start, got {type(data).__name__}")
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        v.fail("name", f"expected a non-empty string, got {name!r}")
    walls = tuple(
        Wall(v.vec2(e, w, "from"), v.vec2(e, w, "to"),
             v.positive(e, w, "thickness", DEFAULT_THICKNESS), v.positive(e, w, "height", DEFAULT_HEIGHT),
             v.label(e, w))
        for w, e in v.entries(data, "walls", required=("from", "to"), optional=("thickness", "height")))
    for i, wall in enumerate(walls):
        if wall.start == wall.end:
            v.fail(f"walls[{i}]", f"from and to are the same point {list(wall.start)}")
    boxes = tuple(
        Box(v.vec2(e, w, "center"), v.size2(e, w, "size"), v.number(e, w, "yaw", 0.0),
            v.positive(e, w, "height", DEFAULT_HEIGHT), v.label(e, w))
        for w, e in v.entries(data, "boxes", required=("center", "size"), optional=("yaw", "height")))
    cylinders = tuple(
        Cylinder(v.vec2(e, w, "center"), v.positive(e, w, "radius"),
                 v.positive(e, w, "height", DEFAULT_HEIGHT), v.label(e, w))
        for w, e in v.entries(data, "cylinders", required=("center", "radius"), optional=("height",)))
    moving = tuple(v.moving(e, w) for w, e in v.entries(
        data, "moving", required=("shape", "keyframes"),
        optional=("radius", "size", "height", "interpolation", "loop", "phase")))
    start = Pose2D(*v.pose(data["start"], "start")) if "start" in data else Pose2D(0.0, 0.0, 0.0)
    goals = tuple(Pose2D(*v.pose(e, w))
                  for w, e in v.entries(data, "goals", required=("x", "y"), optional=("yaw",)))
    starts = tuple(Pose2D(*pose) for pose in v.start_list(data.get("starts") or []))
    run = {k: v.positive(data, "top level", k) for k in RUN_KEYS if k in data}
    extra = MappingProxyType({**{k: val for k, val in data.items() if k in METADATA_KEYS}, **run})
    return World(name, walls, boxes, cylinders, start, goals, source, extra, starts, moving,
                 unknown_key_warnings(data, source))


def unknown_key_warnings(data: dict, source: str) -> tuple[str, ...]:
    """One line per top-level key that is neither a world key nor generator metadata, with the closest
    known key as a suggestion: a misspelt ``movng`` would otherwise drop the obstacles silently."""
    known = WORLD_KEYS + RUN_KEYS + METADATA_KEYS
    lines = []
    for key in data:
        if key not in known:
            close = difflib.get_close_matches(str(key), known, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            lines.append(f"{source}: unknown world key {key!r}{hint}; ignored")
    return tuple(lines)


def _moving_dict(m: MovingObstacle) -> dict:
    extent = {"radius": m.radius} if m.shape == "cylinder" else {"size": list(m.size)}
    return {"shape": m.shape, **extent, "height": m.height, "interpolation": m.interpolation, "loop": m.loop,
            "phase": m.phase, "keyframes": [list(frame) for frame in m.keyframes]}


def check_clearance(world: World, robot_radius: float) -> None:
    """The start, the robots' starts and every goal must be at least robot_radius away from all obstacles."""
    poses = [("start", world.start)] + [(f"starts[{i}]", p) for i, p in enumerate(world.starts)] \
        + [(f"goals[{i}]", g) for i, g in enumerate(world.goals)]
    check_poses_clear(world, poses, robot_radius)


def check_poses_clear(world: World, poses: list[tuple[str, Pose2D]], robot_radius: float) -> None:
    """Each (label, pose) at least robot_radius away from all obstacles; the error names the label."""
    for where, pose in poses:
        dist, label = world.nearest_obstacle(pose.x, pose.y)
        if dist == 0.0:
            raise ValueError(f"{world.source}: {where} ({pose.x}, {pose.y}) is inside {label}")
        if dist < robot_radius:
            raise ValueError(f"{world.source}: {where} ({pose.x}, {pose.y}) is {dist:.3f} m from {label}, "
                             f"closer than the robot radius {robot_radius}")


def write_world(world: World, path: str | Path, header: str = "") -> None:
    """Dump a (generated) world as a world file, with an optional comment header."""
    def dump(value, flow) -> str:
        return yaml.safe_dump(value, sort_keys=False, default_flow_style=flow, width=math.inf).rstrip()

    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    for key, value in world.to_dict().items():
        if isinstance(value, list) and value and isinstance(value[0], dict):
            # One entry per line, as in the hand-written worlds.
            lines.append(f"{key}:")
            lines += [f"  - {dump(item, True)}" for item in value]
        elif isinstance(value, (dict, list)):
            lines.append(f"{key}: {dump(value, True)}")
        else:
            lines.append(dump({key: value}, False))
    Path(path).write_text("\n".join(lines) + "\n")
