"""Several simplebots in one world: one simulator with robots robot1 .. robot<N>, and a move_base per
robot in its namespace (/robot1/move_base, /robot1/move_base_simple/goal, ...), with frames robot1/odom,
robot1/base_link, ... on the shared /tf. The simulator places each robot's odom frame in ``map`` at
its start pose, so goals may be given in ``map`` (docs/design.md §5).

    python -m simplebot_navigation.launch multi_navigation robots:=3 [starts:="x,y,yaw;x,y,yaw;..."]

The number of robots is an argument, so the items come from ``generate(args)``.
"""

from simplebot_navigation.launch.description import Arg, Include
from simplebot_navigation.launch.simplebot_args import COLLISION_MONITOR, RADIUS, ROBOT, RTF, TIGHT, WORLD

LAUNCH_DIR = "$(find simplebot_navigation)/launch_py"
DEFAULT_MAX_ROBOTS = 32

ARGS = [
    Arg("robots", default="3", doc="how many robots (robot1 .. robot<N>), at most max_robots"),
    Arg("max_robots", default=str(DEFAULT_MAX_ROBOTS),
        doc="the most robots:= may ask for (each robot is a move_base process of about 250 MB and a core's third)"),
    WORLD,
    Arg("starts", default="",
        doc="x,y,yaw;x,y,yaw;... in the world frame, one per robot (empty: the world file's starts list)"),
    ROBOT,
    RADIUS,
    RTF,
    TIGHT,
    COLLISION_MONITOR,
    Arg("respawn", default="true", choices=("true", "false"),
        doc="restart the simulator and each move_base when they exit (roslaunch's respawn)"),
]


def generate(args: dict[str, str]) -> list:
    if not args["max_robots"].isdigit() or int(args["max_robots"]) < 1:
        raise ValueError(f"max_robots:={args['max_robots']!r} must be a whole number >= 1")
    if not args["robots"].isdigit() or not 1 <= int(args["robots"]) <= int(args["max_robots"]):
        raise ValueError(f"robots:={args['robots']!r} must be a whole number from 1 to max_robots "
                         f"({args['max_robots']}; max_robots:=N raises it)")
    namespaces = [f"robot{i}" for i in range(1, int(args["robots"]) + 1)]
    return [
        Include(file=f"{LAUNCH_DIR}/simulator.py", args={
            "world": "$(arg world)", "robot": "$(arg robot)", "radius": "$(arg radius)", "rtf": "$(arg rtf)",
            "respawn": "$(arg respawn)", "namespaces": " ".join(namespaces), "starts": "$(arg starts)"}),
        *(Include(file=f"{LAUNCH_DIR}/move_base.py", args={
            "robot": "$(arg robot)", "radius": "$(arg radius)", "tight": "$(arg tight)", "respawn": "$(arg respawn)",
            "namespace": namespace, "collision_monitor": "$(arg collision_monitor)"})
          for namespace in namespaces),
    ]
