"""Where each launchable executable lives: (package, type) -> Python module with a main() and a node class."""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass


@dataclass(frozen=True)
class Executable:
    module: str
    node_class: str | None  # None: the module runs only as its own process


EXECUTABLES: dict[tuple[str, str], Executable] = {
    ("simplebot_navigation", "simulator"): Executable("simplebot_navigation.ros.simulator.simulator_node", "SimulatorNode"),
    ("amcl", "amcl"): Executable("simplebot_navigation.ros.amcl.amcl_node", "AmclNode"),
    ("move_base", "move_base"): Executable("simplebot_navigation.ros.move_base.move_base_node", "MoveBaseNode"),
    ("simplebot_navigation", "viewer"): Executable("simplebot_navigation.viewer.node", "ViewerNode"),
    ("simplebot_navigation", "collision_monitor"): Executable("simplebot_navigation.ros.collision_monitor_node",
                                                              "CollisionMonitorNode"),
    ("simplebot_navigation", "foxglove_bridge"): Executable("simplebot_navigation.ros.tools.foxglove_bridge",
                                                            "FoxgloveBridge"),
    ("map_server", "map_server"): Executable("simplebot_navigation.ros.map_server_node", "MapServerNode"),
    ("map_server", "map_saver"): Executable("simplebot_navigation.ros.map_saver_node", None),
    ("simplebot_navigation", "slam"): Executable("simplebot_navigation.ros.slam.slam_node", "SlamNode"),
    ("simplebot_navigation", "explore"): Executable("simplebot_navigation.ros.slam.explore_node", "ExploreNode"),
}


class ExecutableNotFound(LookupError):
    pass


def resolve_executable(pkg: str, node_type: str) -> Executable:
    """Find an executable; pkg "python" runs any module given as type (its ``main()``), as ``python -m`` would."""
    if pkg == "python":
        module, _, cls = node_type.partition(":")
        exe = Executable(module, cls or None)
    else:
        exe = EXECUTABLES.get((pkg, node_type))
        if exe is None:
            known = ", ".join(f"{p}/{t}" for p, t in sorted(EXECUTABLES))
            raise ExecutableNotFound(f"no executable '{node_type}' in package '{pkg}' (known: {known})")
    try:
        found = importlib.util.find_spec(exe.module) is not None
    except ModuleNotFoundError:
        found = False
    if not found:
        raise ExecutableNotFound(f"{pkg}/{node_type} is not available in this installation: "
                                 f"module {exe.module} does not exist yet")
    return exe
