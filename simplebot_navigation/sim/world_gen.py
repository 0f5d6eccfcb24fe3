"""Generated worlds: doors sized relative to the robot, seeded random clutter, and seeded forests.

The shipped ``doors.yaml``, ``clutter.yaml`` and ``office.yaml`` are ``doors_world(0.6)``,
``clutter_world(0)`` and ``office.office_world()``; ``python -m simplebot_navigation.sim.world_gen``
rewrites them (a test checks they match).
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType

import numpy as np

from simplebot_description import WORLDS_DIR

from simplebot_navigation.sim.cspace import DEFAULT_MARGIN, analyse
from simplebot_navigation.sim.office import office_world
from simplebot_navigation.sim.world import Box, Cylinder, Pose2D, Wall, World, _shape_distance, write_world

OUTER_THICKNESS = 0.2


def _outer_walls(xmin: float, ymin: float, xmax: float, ymax: float) -> list[Wall]:
    corners = [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]
    return [Wall(a, b, OUTER_THICKNESS) for a, b in zip(corners, corners[1:] + corners[:1])]


def door_goal_name(ratio: float) -> str:
    return f"door_{ratio:g}x"


def doors_world(robot_width: float, ratios=(1.25, 1.5, 2.0), bay_width: float = 3.0,
                hall_depth: float = 3.0, bay_depth: float = 4.0) -> World:
    """A hall (y < 0) and a row of closed bays (y > 0), each entered through one door.

    Door i is ``ratios[i] * robot_width`` wide (clear opening between the wall ends). The bays are
    separated by walls, so goal ``door_<ratio>x`` (the middle of bay i) can only be reached through
    door i: a scenario picks a door by picking the goal, ``world.goal(door_goal_name(1.5))``.
    The robot starts in the middle of the hall, facing the doors.
    """
    if not (isinstance(robot_width, (int, float)) and math.isfinite(robot_width) and robot_width > 0):
        raise ValueError(f"doors_world: robot_width must be a positive number, got {robot_width!r}")
    if not ratios:
        raise ValueError("doors_world: ratios must not be empty")
    widths = [round(r * robot_width, 3) for r in ratios]
    for ratio, width in zip(ratios, widths):
        if not 0 < width <= bay_width - 0.2:
            raise ValueError(f"doors_world: door ratio {ratio} gives width {width} m, which must be "
                             f"> 0 and fit the {bay_width} m bay with 0.1 m of wall on each side")
    half = len(ratios) * bay_width / 2
    walls = _outer_walls(-half, -hall_depth, half, bay_depth)
    x = -half
    doors, goals = [], []
    for i, (ratio, width) in enumerate(zip(ratios, widths)):
        centre = round(-half + (i + 0.5) * bay_width, 3)
        walls.append(Wall((x, 0.0), (round(centre - width / 2, 4), 0.0)))
        x = round(centre + width / 2, 4)
        if i:
            walls.append(Wall((-half + i * bay_width, 0.0), (-half + i * bay_width, bay_depth)))
        name = door_goal_name(ratio)
        goals.append(Pose2D(centre, bay_depth / 2, round(math.pi / 2, 4), name))
        doors.append({"goal": name, "ratio": ratio, "width": width, "center": [centre, 0.0]})
    walls.append(Wall((x, 0.0), (half, 0.0)))
    extra = {"robot_width": robot_width, "doors": doors}
    return World("doors", tuple(walls), (), (), Pose2D(0.0, -hall_depth / 2, round(math.pi / 2, 4)),
                 tuple(goals), "<doors_world>", MappingProxyType(extra))


def clutter_world(seed: int = 0, size=(12.0, 10.0), n_boxes: int = 8, n_cylinders: int = 8,
                  min_gap: float = 1.0, keep_clear: float = 1.0, max_tries: int = 20000) -> World:
    """A walled room with seeded random boxes and cylinders, start on the left, goals on the right.

    Any two obstacles (and any obstacle and the walls) are at least ``min_gap`` apart, measured
    between bounding circles, so a robot narrower than min_gap can reach every goal; start and goals
    keep ``keep_clear`` from every obstacle. Same seed, same world. ValueError if the requested
    obstacles do not fit.
    """
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ValueError(f"clutter_world: seed must be an int, got {seed!r}")
    sx, sy = size
    rng = np.random.default_rng(seed)
    start = Pose2D(-sx / 2 + 1.0, 0.0, 0.0)
    goals = (Pose2D(sx / 2 - 1.0, 0.0, 0.0, "east"), Pose2D(sx / 2 - 1.0, sy / 2 - 1.0, 0.0, "north_east"),
             Pose2D(sx / 2 - 1.0, -sy / 2 + 1.0, 0.0, "south_east"), Pose2D(0.0, sy / 2 - 1.0, 0.0, "north"))
    placed: list[tuple[float, float, float]] = []  # bounding circles (x, y, r)
    boxes, cylinders = [], []
    kinds = ["box"] * n_boxes + ["cylinder"] * n_cylinders
    tries = 0
    for kind in kinds:
        while True:
            tries += 1
            if tries > max_tries:
                raise ValueError(f"clutter_world: could not place {n_boxes} boxes and {n_cylinders} cylinders "
                                 f"{min_gap} m apart in a {sx} x {sy} m room (seed {seed})")
            if kind == "box":
                bx, by = (round(float(v), 3) for v in rng.uniform(0.3, 1.2, 2))
                yaw = round(float(rng.uniform(0.0, math.pi)), 3)
                r = math.hypot(bx, by) / 2
            else:
                r = round(float(rng.uniform(0.1, 0.4)), 3)
            margin = OUTER_THICKNESS / 2 + min_gap + r
            x = round(float(rng.uniform(-sx / 2 + margin, sx / 2 - margin)), 3)
            y = round(float(rng.uniform(-sy / 2 + margin, sy / 2 - margin)), 3)
            if any(math.hypot(x - px, y - py) < r + pr + min_gap for px, py, pr in placed):
                continue
            if any(math.hypot(x - p.x, y - p.y) < r + keep_clear for p in (start, *goals)):
                continue
            break
        placed.append((x, y, r))
        if kind == "box":
            boxes.append(Box((x, y), (bx, by), yaw))
        else:
            cylinders.append(Cylinder((x, y), r))
    walls = _outer_walls(-sx / 2, -sy / 2, sx / 2, sy / 2)
    extra = {"seed": seed, "min_gap": min_gap}
    return World("clutter", tuple(walls), tuple(boxes), tuple(cylinders), start, goals, "<clutter_world>",
                 MappingProxyType(extra))


FOREST_SHAPES = MappingProxyType({"cylinder": 0.85, "box": 0.1, "wall": 0.05})
FOREST_APPROACH = 3.0
FOREST_GOAL = "exit"
_BOUNDARY_SPACING = 0.01


def forest_world(seed: int = 0, occupancy: float = 0.12, field=(10.0, 4.5), min_passage: float = 0.75,
                 robot_radius: float = 0.25, shapes=FOREST_SHAPES, cylinder_diameter: float = 0.15,
                 margin: float = DEFAULT_MARGIN, max_misses: int = 1500) -> World:
    """A corridor crossing a field of thin cylinders with some boxes and short wall segments.

    The field is ``field = (depth, width)`` metres (x from 0 to depth); the corridor's clear width is
    the field's width, so the robot has to cross it. It starts ``FOREST_APPROACH`` m before the field
    and goal ``FOREST_GOAL`` is as far past it. Obstacles are drawn one by one, kinds weighted by
    ``shapes`` (kind -> share of the draws), and kept only if they stay ``min_passage`` clear of every
    other surface and of the side walls. Drawing stops when they cover ``occupancy`` of the field, or
    when ``max_misses`` draws in a row were rejected: the field is then as dense as the passage rule
    allows, which for 0.15 m cylinders 0.75 m apart is only about 2 % of the area, so the default
    asks for the densest field. ``world.extra`` records the occupancy reached and the C-space metrics
    (see cspace.analyse, for a disc of robot_radius + margin); ValueError naming the seed if the goal
    is blocked or unreachable. Same arguments, same world.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"forest_world: seed must be an int >= 0, got {seed!r}")
    unknown = sorted(set(shapes) - set(FOREST_SHAPES))
    if unknown or not shapes or min(shapes.values()) < 0 or sum(shapes.values()) <= 0:
        raise ValueError(f"forest_world: shapes must weigh {', '.join(FOREST_SHAPES)} with weights >= 0, "
                         f"got {dict(shapes)}")
    depth, width = field
    for name, value in (("occupancy", occupancy), ("field depth", depth), ("field width", width),
                        ("min_passage", min_passage), ("cylinder_diameter", cylinder_diameter)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"forest_world: {name} must be a positive number, got {value!r}")
    rng = np.random.default_rng(seed)
    kinds, cumulative = list(shapes), np.cumsum(list(shapes.values())) / sum(shapes.values())
    field_obstacles = _Field(width, min_passage)
    misses = 0
    while field_obstacles.covered < occupancy * depth * width and misses < max_misses:
        kind = kinds[min(int(np.searchsorted(cumulative, rng.random(), side="right")), len(kinds) - 1)]
        if field_obstacles.place(_forest_obstacle(rng, kind, depth, width, cylinder_diameter)):
            misses = 0
        else:
            misses += 1
    placed = field_obstacles.shapes
    half = width / 2 + OUTER_THICKNESS / 2  # wall centre lines, so the clear width is the field's
    walls = _outer_walls(-FOREST_APPROACH - 1.0, -half, depth + FOREST_APPROACH + 1.0, half)
    walls += [s for s in placed if isinstance(s, Wall)]
    goal = Pose2D(depth + FOREST_APPROACH, 0.0, 0.0, FOREST_GOAL)
    knobs = {"seed": seed, "occupancy": round(field_obstacles.covered / (depth * width), 4),
             "field": [depth, width], "min_passage": min_passage}
    world = World("forest", tuple(walls), tuple(s for s in placed if isinstance(s, Box)),
                  tuple(s for s in placed if isinstance(s, Cylinder)), Pose2D(-FOREST_APPROACH, 0.0, 0.0),
                  (goal,), f"forest:{seed}", MappingProxyType(knobs))
    metrics = analyse(world, robot_radius, margin=margin)
    cspace = {"robot_radius": robot_radius, "margin": margin,
              "narrowest_passage": round(metrics.narrowest_passage, 3),
              "path_length": round(metrics.path_length, 3), "tortuosity": round(metrics.tortuosity, 4)}
    return replace(world, extra=MappingProxyType({**knobs, "cspace": cspace}))


def _forest_obstacle(rng: np.random.Generator, kind: str, depth: float, width: float, diameter: float):
    x, y = round(float(rng.uniform(0.0, depth)), 3), round(float(rng.uniform(-width / 2, width / 2)), 3)
    if kind == "cylinder":
        return Cylinder((x, y), diameter / 2)
    yaw = round(float(rng.uniform(0.0, math.pi)), 3)
    if kind == "box":
        return Box((x, y), tuple(round(float(v), 3) for v in rng.uniform(0.2, 0.5, 2)), yaw)
    half = float(rng.uniform(0.3, 0.7))
    dx, dy = half * math.cos(yaw), half * math.sin(yaw)
    return Wall((round(x - dx, 3), round(y - dy, 3)), (round(x + dx, 3), round(y + dy, 3)))


class _Field:
    """The obstacles placed so far, with their centres and bounding radii for a quick first check.

    The gap between two convex shapes is the least distance from one's outline to the other, so
    outlines sampled 1 cm apart err by at most half of that; the check demands it on top.
    """

    def __init__(self, width: float, min_passage: float):
        self.width = width
        self.need = min_passage + _BOUNDARY_SPACING / 2
        self.shapes: list[Box | Cylinder | Wall] = []
        self.covered = 0.0
        self._centres = np.empty((0, 2))
        self._reach = np.empty(0)
        self._round = np.empty(0, dtype=bool)

    def place(self, shape) -> bool:
        """Keep the shape if it leaves every passage at least min_passage wide."""
        solid = shape.as_box() if isinstance(shape, Wall) else shape
        round_ = isinstance(solid, Cylinder)
        if round_:
            reach = half_height = solid.radius
        else:
            reach = math.hypot(*solid.size) / 2
            c, s = abs(math.cos(solid.yaw)), abs(math.sin(solid.yaw))
            half_height = (s * solid.size[0] + c * solid.size[1]) / 2
        if abs(solid.center[1]) + half_height > self.width / 2 - self.need:
            return False
        gaps = np.hypot(*(self._centres - solid.center).T) - self._reach - reach
        close = np.flatnonzero(gaps < self.need)
        if round_ and self._round[close].any():
            return False  # between two circles the bounding gap is the exact gap
        outline = _outline(solid) if len(close) else None
        for i in close:
            other = self.shapes[i]
            other_solid = other.as_box() if isinstance(other, Wall) else other
            if np.min(_shape_distance(other_solid, outline)) < self.need:
                return False
        self.shapes.append(shape)
        self.covered += math.pi * reach ** 2 if round_ else solid.size[0] * solid.size[1]
        self._centres = np.vstack((self._centres, solid.center))
        self._reach = np.append(self._reach, reach)
        self._round = np.append(self._round, round_)
        return True


def _outline(solid: Box | Cylinder) -> np.ndarray:
    """Points along the shape's outline 1 cm apart."""
    if isinstance(solid, Cylinder):
        n = math.ceil(2 * math.pi * solid.radius / _BOUNDARY_SPACING)
        angles = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
        return np.column_stack((np.cos(angles), np.sin(angles))) * solid.radius + solid.center
    hx, hy = solid.size[0] / 2, solid.size[1] / 2
    corners = np.array([(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy), (-hx, -hy)])
    local = np.concatenate([np.linspace(a, b, math.ceil(np.hypot(*(b - a)) / _BOUNDARY_SPACING), endpoint=False)
                            for a, b in zip(corners[:-1], corners[1:])])
    c, s = math.cos(solid.yaw), math.sin(solid.yaw)
    return local @ np.array([[c, s], [-s, c]]) + solid.center


def main() -> None:
    write_world(doors_world(0.6), WORLDS_DIR / "doors.yaml",
                "Doors of 1.25x, 1.5x and 2x the width of a 0.6 m robot (the box, or the round body of\n"
                "radius 0.3): each door leads into its own bay, so goal door_<ratio>x forces that door.\n"
                "Generated by simplebot_navigation.sim.world_gen.doors_world(0.6); other robot widths:\n"
                "call doors_world(width).")
    write_world(clutter_world(0), WORLDS_DIR / "clutter.yaml",
                "Seeded random clutter: simplebot_navigation.sim.world_gen.clutter_world(seed=0).\n"
                "Obstacles are at least 1 m apart, so every goal is reachable.")
    write_world(office_world(), WORLDS_DIR / "office.yaml",
                "An office floor for SLAM: a corridor loop of about 100 m around a block of rooms, rooms off its\n"
                "outer side, doors at least 1.2 m clear, an alcove, a kitchen niche and a lobby along the corridor.\n"
                "Generated by simplebot_navigation.sim.office.office_world(); goals room_a ... room_p, one per room,\n"
                "and corridor_nw, corridor_ne, corridor_se, kitchen, lobby.")


if __name__ == "__main__":
    main()
