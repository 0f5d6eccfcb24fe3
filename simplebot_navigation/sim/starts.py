"""Where each robot starts: the world's ``starts`` list or ``x,y,yaw;x,y,yaw;...`` from the command line,
checked against the obstacles and against each other before anything is built."""

from __future__ import annotations

import itertools
import math

from simplebot_description import RobotDescription

from simplebot_navigation.sim.world import Pose2D, World, check_poses_clear


def parse_starts(text: str) -> tuple[Pose2D, ...]:
    """``"x,y,yaw;x,y,yaw"`` (yaw may be left out) as poses; the error names the entry."""
    poses = []
    for i, entry in enumerate(text.split(";"), 1):
        fields = [field.strip() for field in entry.split(",")]
        try:
            numbers = [float(field) for field in fields]
        except ValueError:
            numbers = []
        if len(numbers) not in (2, 3) or not all(math.isfinite(n) for n in numbers):
            raise ValueError(f"starts: entry {i} {entry.strip()!r} is not x,y or x,y,yaw in metres and radians")
        poses.append(Pose2D(*numbers))
    return tuple(poses)


def robot_starts(world: World, names: list[str], text: str, description: RobotDescription) -> tuple[Pose2D, ...]:
    """One start per robot name: from ``text`` if given, else the world's ``starts`` (one robot: its ``start``).

    Each start is named after its robot; a start inside or too close to an obstacle, two robots that
    would overlap, or fewer starts than robots is a ValueError naming the start.
    """
    if text.strip():
        given, origin = parse_starts(text), "the starts argument"
    elif len(names) == 1:
        given, origin = (world.start,), f"{world.source}'s start"
    else:
        given, origin = world.starts, f"{world.source}'s starts list"
    if len(given) < len(names):
        raise ValueError(f"{len(names)} robots but {len(given)} start(s) in {origin}: give one x,y,yaw per robot "
                         f"(starts:=\"x,y,yaw;x,y,yaw;...\") or add them to the world's starts")
    starts = tuple(Pose2D(p.x, p.y, p.yaw, name) for p, name in zip(given, names))
    check_poses_clear(world, [(f"start of {p.name}", p) for p in starts], description.inscribed_radius)
    apart = 2 * description.circumscribed_radius
    for a, b in itertools.combinations(starts, 2):
        distance = math.hypot(a.x - b.x, a.y - b.y)
        if distance < apart:
            raise ValueError(f"starts of {a.name} ({a.x}, {a.y}) and {b.name} ({b.x}, {b.y}) are {distance:.2f} m "
                             f"apart: the robots would overlap (they need {apart:.2f} m)")
    return starts
