"""Several simplebots in one world: one simulator with robots robot1 .. robot<N>, and a move_base per
robot in its namespace (/robot1/move_base, /robot1/move_base_simple/goal, ...), with frames robot1/odom,
robot1/base_link, ... on the shared /tf. The simulator places each robot's odom frame in ``map`` at
its start pose, so goals may be given in ``map`` (docs/design.md §5). With ``map:=...`` one map_server serves the
map and each robot's amcl publishes ``map`` -> its odom instead, starting at the robot's start. With ``slam:=true``
each robot maps on its own: a slam node per robot publishes its map on ``robot<i>/map`` and ``map`` -> its odom,
starting at the robot's start, so every robot's map is in the world's frame.

    python -m simplebot_navigation.launch multi_navigation robots:=3 [starts:="x,y,yaw;x,y,yaw;..."]

The number of robots is an argument, so the items come from ``generate(args)``.
"""

from simplebot_navigation.launch.description import Arg, Include, Node, Param
from simplebot_navigation.launch.simplebot_args import (COLLISION_MONITOR, ENCODER_NOISE, GIVEN_MAP, MAP, MAX_SPEED,
                                                        MOVING_OBSTACLES, RADIUS, ROBOT, RTF, SLAM, TIGHT,
                                                        WITH_ENCODER_NOISE, WORLD)
from simplebot_navigation.sim.starts import parse_starts
from simplebot_navigation.sim.world_loader import load_world

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
    MAP,
    ENCODER_NOISE,
    MAX_SPEED,
    MOVING_OBSTACLES,
    SLAM,
]


def initial_poses(args: dict[str, str], count: int) -> list[str]:
    """Each robot's amcl (or slam) initial pose on a map: its start (the starts argument, or the world's starts)."""
    if not args["map"] and args["slam"] != "true":
        return [""] * count
    poses = parse_starts(args["starts"]) if args["starts"].strip() else load_world(args["world"]).starts
    return [f"{p.x},{p.y},{p.yaw}" for p in poses[:count]] + [""] * (count - len(poses))


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
            "respawn": "$(arg respawn)", "namespaces": " ".join(namespaces), "starts": "$(arg starts)",
            "encoder_noise": WITH_ENCODER_NOISE, "map_to_odom": "$(eval map == '' and slam != 'true')",
            "max_speed": "$(arg max_speed)"}),
        *(Include(file=f"{LAUNCH_DIR}/move_base.py", args={
            "robot": "$(arg robot)", "radius": "$(arg radius)", "tight": "$(arg tight)", "respawn": "$(arg respawn)",
            "namespace": namespace, "collision_monitor": "$(arg collision_monitor)", "map": "$(arg map)",
            "max_speed": "$(arg max_speed)", "moving_obstacles": "$(arg moving_obstacles)", "slam": "$(arg slam)"})
          for namespace in namespaces),
        # On a map: one map_server for all, an amcl per robot starting at the robot's start.
        Node(pkg="map_server", type="map_server", name="map_server", output="screen", respawn="$(arg respawn)",
             if_=GIVEN_MAP, params=[Param("yaml_filename", "$(arg map)")]),
        *(Include(file=f"{LAUNCH_DIR}/amcl.py", if_=GIVEN_MAP, args={
            "world": "$(arg world)", "namespace": namespace, "initial_pose": pose, "respawn": "$(arg respawn)"})
          for namespace, pose in zip(namespaces, initial_poses(args, len(namespaces)))),
        # Or a slam per robot, each starting at its robot's start.
        *(Include(file=f"{LAUNCH_DIR}/slam.py", if_="$(arg slam)", args={
            "world": "$(arg world)", "namespace": namespace, "initial_pose": pose, "respawn": "$(arg respawn)"})
          for namespace, pose in zip(namespaces, initial_poses(args, len(namespaces)))),
    ]
