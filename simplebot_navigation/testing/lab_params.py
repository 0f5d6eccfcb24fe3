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


def global_costmap_params() -> dict:
    return move_base_tree()["global_costmap"]


def local_costmap_params() -> dict:
    return move_base_tree()["local_costmap"]
