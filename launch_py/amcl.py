"""amcl for one simplebot on a map, in the style of ROS 1's amcl_diff.launch: config/map/amcl.yaml, the robot's
frames (prefixed in a namespace), both lidars, the one shared /map, and the initial pose.

The initial pose is ``initial_pose:="x,y,yaw"`` in the map frame, or, left empty, the world's start: a map
exported from a world has the world's coordinates, so that is where the simulated robot stands. Any tool
may move it later on ``initialpose`` (RViz's and the viewer's 2D Pose Estimate, Foxglove).
"""

from simplebot_navigation.launch.description import Arg, Group, Node, Param, Remap, RosParam
from simplebot_navigation.launch.simplebot_args import NAMESPACE, WORLD, start_pose

CONFIG = "$(find simplebot_navigation)/config"

ARGS = [
    WORLD,
    NAMESPACE,
    Arg("initial_pose", default="", doc="x,y,yaw of the robot in the map frame (empty: the world's start)"),
    Arg("respawn", default="true", choices=("true", "false"), doc="restart amcl when it exits"),
]


def generate(args: dict[str, str]) -> list:
    x, y, yaw = start_pose(args["world"], args["initial_pose"])
    prefix = f"{args['namespace']}/" if args["namespace"] else ""
    return [Group(ns=args["namespace"], children=[
        Node(pkg="amcl", type="amcl", name="amcl", output="screen", respawn=args["respawn"], params=[
            RosParam(file=f"{CONFIG}/map/amcl.yaml"),
            Param("initial_pose_x", x), Param("initial_pose_y", y), Param("initial_pose_a", yaw),
            Param("odom_frame_id", prefix + "odom"),
            Param("base_frame_id", prefix + "base_link"),
        ], remaps=[
            # one map for all robots
            Remap("map", "/map"),
        ]),
    ])]
