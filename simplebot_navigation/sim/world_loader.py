"""load_world: a world by built-in name or file, in the world format (world.py) or as a map_server
map (map_import.py). It sits above both so that neither has to import the other."""

from __future__ import annotations

import math
from pathlib import Path

import yaml

from simplebot_description import GENERATED_WORLD, builtin_worlds, world_name_problem, world_path

from simplebot_navigation.sim.crowd import crowd_world, people_world
from simplebot_navigation.sim.forest import benchmark_forest
from simplebot_navigation.sim.map_import import world_from_map
from simplebot_navigation.sim.world import World, check_clearance, world_from_dict


GENERATED_FAMILIES = {"forest": benchmark_forest, "crowd": crowd_world, "people": people_world}


def generated_world(name: str) -> World | None:
    """The world a generated-family name stands for ("forest", "forest:12", "crowd:3", "people:7"; no
    seed is seed 0), or None for other names."""
    match = GENERATED_WORLD.fullmatch(name)
    if match is None:
        return None
    return GENERATED_FAMILIES[match.group(1)](int(match.group(2) or 0))


def load_world(name_or_path: str | Path, robot_radius: float = 0.0) -> World:
    """Load a built-in world by name, a generated one ("forest:<seed>", "crowd:<seed>", "people:<seed>"), a world YAML file, or a
    map_server map.yaml.

    ``robot_radius`` is the clearance the start and the goals need from every obstacle (pass the
    robot's inscribed radius, or 0 to check only that they are not inside an obstacle).
    Raises ValueError naming the file and the entry for anything malformed.
    """
    if isinstance(robot_radius, bool) or not isinstance(robot_radius, (int, float)) \
            or not math.isfinite(robot_radius) or robot_radius < 0:
        raise ValueError(f"robot_radius must be a finite number >= 0; got {robot_radius!r}")
    world = generated_world(str(name_or_path))
    if world is not None:
        check_clearance(world, robot_radius)
        return world
    problem = world_name_problem(str(name_or_path))
    if problem:
        raise ValueError(f"unknown world {str(name_or_path)!r}: {problem}")
    path = world_path(str(name_or_path)) if str(name_or_path) in builtin_worlds() else Path(name_or_path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{path.name}: not valid YAML: {exc}") from exc
    if isinstance(data, dict) and "image" in data:
        world = world_from_map(data, path)
    else:
        world = world_from_dict(data, source=path.name, default_name=path.stem)
    check_clearance(world, robot_radius)
    return world
