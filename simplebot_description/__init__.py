"""The simplebot robot model (URDF via xacro) and the built-in simulator worlds."""

from pathlib import Path

from .robot import BODIES, FixedJoint, RobotDescription, ScanParams, robot_description, urdf_string

WORLDS_DIR = Path(__file__).resolve().parent / "worlds"


def builtin_worlds() -> list[str]:
    """Names accepted by world_path() (and by the simulator's --world)."""
    return sorted(p.stem for p in WORLDS_DIR.glob("*.yaml"))


def world_path(name: str) -> Path:
    """Path of a built-in world file; ValueError lists the known names."""
    path = WORLDS_DIR / f"{name}.yaml"
    if "/" in name or not path.is_file():
        raise ValueError(f"unknown world {name!r}; built-in worlds: {', '.join(builtin_worlds())}")
    return path


__all__ = [
    "BODIES",
    "FixedJoint",
    "RobotDescription",
    "ScanParams",
    "WORLDS_DIR",
    "builtin_worlds",
    "robot_description",
    "urdf_string",
    "world_path",
]
