"""slam (and explore) for one simplebot, in the style of slam_toolbox's online_async_launch.py: config/slam/slam.yaml,
the robot's frames (prefixed in a namespace), both lidars, and the start pose.

The map's frame is the world's: the robot starts at ``initial_pose:="x,y,yaw"`` or, left empty, at the world's
start, so that a map built in a simulated world lines up with the world (and with its exported map).
"""

from simplebot_navigation.launch.description import Arg, Group, Node, Param, RosParam
from simplebot_navigation.launch.simplebot_args import NAMESPACE, WORLD, start_pose

CONFIG = "$(find simplebot_navigation)/config/slam"

ARGS = [
    WORLD,
    NAMESPACE,
    Arg("initial_pose", default="", doc="x,y,yaw of the robot in the map frame (empty: the world's start)"),
    Arg("explore", default="false", choices=("true", "false"), doc="also drive to the map's frontiers"),
    Arg("respawn", default="true", choices=("true", "false"), doc="restart slam and explore when they exit"),
]


def generate(args: dict[str, str]) -> list:
    x, y, yaw = start_pose(args["world"], args["initial_pose"])
    prefix = f"{args['namespace']}/" if args["namespace"] else ""
    return [Group(ns=args["namespace"], children=[
        Node(pkg="simplebot_navigation", type="slam", name="slam", output="screen", respawn=args["respawn"], params=[
            RosParam(file=f"{CONFIG}/slam.yaml"),
            Param("map_start_pose", [x, y, yaw]),
            Param("odom_frame", prefix + "odom"),
            Param("base_frame", prefix + "base_link"),
        ]),
        Node(pkg="simplebot_navigation", type="explore", name="explore", output="screen", respawn=args["respawn"],
             if_=args["explore"], params=[
            RosParam(file=f"{CONFIG}/explore.yaml"),
            Param("robot_base_frame", prefix + "base_link"),
        ]),
    ])]
