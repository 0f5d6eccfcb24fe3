"""The lab's costmap parameter trees, built from config/*.yaml as move_base_local.launch loads them."""

from pathlib import Path

from simplebot_navigation.launch.rosparam import ParamServer
from simplebot_navigation.paths import package_share

CONFIG = Path(package_share("simplebot_navigation")) / "config"


def move_base_tree() -> dict:
    server = ParamServer()
    server.load(str(CONFIG / "costmap_common.yaml"), "/move_base/global_costmap")
    server.load(str(CONFIG / "costmap_common.yaml"), "/move_base/local_costmap")
    server.load(str(CONFIG / "costmap_global_odom.yaml"), "/move_base")
    server.load(str(CONFIG / "costmap_local.yaml"), "/move_base")
    return server.get("/move_base")


def navigation_tree() -> dict:
    """move_base's whole tree as move_base_local.launch loads it: both costmaps and both planners."""
    server = ParamServer()
    for ns in ("/move_base/global_costmap", "/move_base/local_costmap"):
        server.load(str(CONFIG / "costmap_common.yaml"), ns)
    for name in ("costmap_global_odom.yaml", "costmap_local.yaml", "teb_local_planner.yaml", "global_planner.yaml"):
        server.load(str(CONFIG / name), "/move_base")
    return server.get("/move_base")


def global_costmap_params() -> dict:
    return move_base_tree()["global_costmap"]


def local_costmap_params() -> dict:
    return move_base_tree()["local_costmap"]
