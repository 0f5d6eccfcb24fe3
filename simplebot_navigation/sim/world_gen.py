"""Generated worlds: doors sized relative to the robot, and seeded random clutter.

The shipped ``doors.yaml`` and ``clutter.yaml`` are ``doors_world(0.6)`` and ``clutter_world(0)``;
``python -m simplebot_navigation.sim.world_gen`` rewrites them (a test checks they match).
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from simplebot_description import WORLDS_DIR

from .world import Box, Cylinder, Pose2D, Wall, World, write_world

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


def main() -> None:
    write_world(doors_world(0.6), WORLDS_DIR / "doors.yaml",
                "Doors of 1.25x, 1.5x and 2x the width of a 0.6 m robot (the box, or the round body of\n"
                "radius 0.3): each door leads into its own bay, so goal door_<ratio>x forces that door.\n"
                "Generated by simplebot_navigation.sim.world_gen.doors_world(0.6); other robot widths:\n"
                "call doors_world(width).")
    write_world(clutter_world(0), WORLDS_DIR / "clutter.yaml",
                "Seeded random clutter: simplebot_navigation.sim.world_gen.clutter_world(seed=0).\n"
                "Obstacles are at least 1 m apart, so every goal is reachable.")


if __name__ == "__main__":
    main()
