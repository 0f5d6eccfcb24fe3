"""The navigation launch file's arguments for a scenario session (in-process or the launcher's processes)."""

from __future__ import annotations


def launch_args(world: str, robot: str, radius: float, rtf: float, tight: bool,
                respawn: bool = False, foxglove_port: int | None = None,
                collision_monitor: bool = True, map_name: str = "", max_speed: float | None = None,
                moving_obstacles: bool = True, slam: bool = False, explore: bool = False) -> dict[str, str]:
    """The navigation launch file's arguments for a session; by default a node that dies is not respawned,
    so a scenario shows the crash instead of hiding it. With a foxglove_port (0: a free one) the run is
    also served to the Foxglove app on 127.0.0.1. With a map_name (a map YAML or a world) it runs on a map. With a
    max_speed the drive and move_base's speed parameters follow it (docs/reference.md §10). Without
    moving_obstacles nothing is tracked or predicted (every obstacle is a costmap mark). With slam the map is built
    while driving, and with explore (slam implied) the robot drives to its frontiers too (docs/reference.md §13)."""
    args = {"world": str(world), "robot": robot, "radius": str(radius), "rtf": str(rtf),
            "tight": "true" if tight else "false", "respawn": "true" if respawn else "false",
            "collision_monitor": "true" if collision_monitor else "false",
            "moving_obstacles": "true" if moving_obstacles else "false"}
    if map_name:
        args["map"] = map_name
    if slam or explore:
        args["slam"] = "true"
    if explore:
        args["explore"] = "true"
    if max_speed is not None:
        args["max_speed"] = repr(float(max_speed))
    if foxglove_port is not None:
        args.update(foxglove="true", foxglove_port=str(foxglove_port))
    return args
