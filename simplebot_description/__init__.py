"""The simplebot robot model (URDF via xacro) and the built-in simulator worlds."""

import re
from pathlib import Path

from .robot import BODIES, FixedJoint, RobotDescription, ScanParams, robot_description, urdf_string

WORLDS_DIR = Path(__file__).resolve().parent / "worlds"
#: names of the generated world families ("forest", "forest:12", "crowd:3", "people:7"); the simulator
#: generates them (group 1: the family, group 2: the seed, 0 when left out)
GENERATED_WORLD = re.compile(r"(forest|crowd|people)(?::(\d+))?")
WORLD_FILE_SUFFIXES = (".yaml", ".yml")


def builtin_worlds() -> list[str]:
    """Names accepted by world_path() (and by the simulator's --world)."""
    return sorted(p.stem for p in WORLDS_DIR.glob("*.yaml"))


def world_path(name: str) -> Path:
    """Path of a built-in world file; ValueError lists the known names."""
    path = WORLDS_DIR / f"{name}.yaml"
    if "/" in name or not path.is_file():
        raise ValueError(f"unknown world {name!r}; built-in worlds: {', '.join(builtin_worlds())}")
    return path


def world_name_problem(name: str) -> str | None:
    """What is wrong with a world argument, without loading it (None: nothing): a built-in or generated name, or
    an existing YAML file; nothing else is read (a path to any other file is refused, not parsed)."""
    if name in builtin_worlds() or GENERATED_WORLD.fullmatch(name):
        return None
    path = Path(name)
    if path.suffix.lower() not in WORLD_FILE_SUFFIXES:
        return (f"not a built-in world ({', '.join(builtin_worlds())}), a generated one (forest, forest:<seed>, crowd:<seed>, people:<seed>) "
                f"or a world/map file ({' or '.join(WORLD_FILE_SUFFIXES)})")
    if not path.is_file():
        return "no such file"
    return None


__all__ = [
    "BODIES",
    "GENERATED_WORLD",
    "FixedJoint",
    "RobotDescription",
    "ScanParams",
    "WORLDS_DIR",
    "builtin_worlds",
    "robot_description",
    "urdf_string",
    "world_name_problem",
    "world_path",
]
