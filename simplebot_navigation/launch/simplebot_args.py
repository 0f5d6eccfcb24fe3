"""The launch arguments of the simplebot's launch files, declared once here.

As in roslaunch every file declares the arguments it takes (an included file gets only those), so
launch_py/navigation.py, simulator.py, move_base.py and multi_navigation.py list these same objects.
"""

import re

from simplebot_navigation.launch.description import Arg
from simplebot_description import world_name_problem

#: a relative or absolute ROS 2 namespace: tokens of letters, digits and underscores, not starting with a digit
_NAMESPACE = re.compile(r"/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")
MAX_NAMESPACE_LENGTH = 200


def namespace_problem(value: str) -> str | None:
    if value and (len(value) > MAX_NAMESPACE_LENGTH or not _NAMESPACE.fullmatch(value)):
        return (f"not a valid ROS namespace (tokens of letters, digits and '_' separated by '/', none starting "
                f"with a digit, at most {MAX_NAMESPACE_LENGTH} characters)")
    return None


WORLD = Arg("world", default="lab", check=world_name_problem,
            doc="built-in world name (lab, doors, clutter, office, empty), forest:<seed> or a world/map YAML path")
NAMESPACE = Arg("namespace", default="", check=namespace_problem,
                doc="the robot's namespace (e.g. robot1): topics under it, frames prefixed with it; empty: none")
ROBOT = Arg("robot", default="box", choices=("box", "round"), doc="robot body: the lab's 0.9 x 0.6 m box, or round")
RADIUS = Arg("radius", default="0.3", doc="radius of the round body in metres")
RTF = Arg("rtf", default="1.0", doc="real-time factor of the simulation (0: as fast as the nodes allow)")
TIGHT = Arg("tight", default="false", choices=("true", "false"),
            doc="the narrow-door parameter set (config/tight/) over the lab's files")
COLLISION_MONITOR = Arg("collision_monitor", default="true", choices=("true", "false"),
                        doc="put the collision monitor between move_base (cmd_vel_nav) and the base "
                            "(simplebot_controller/cmd_vel); false: move_base drives the base directly")
MAP = Arg("map", default="",
          doc="navigate on a map: a map_server YAML, or a world's name whose map is exported at 0.05 m; "
              "starts map_server and amcl (empty: the lab's odom-only set-up)")
SLAM = Arg("slam", default="false", choices=("true", "false"),
           doc="build the map while driving: the slam node instead of map_server and amcl, the global costmap in its "
               "map frame (map:= is then not used)")
EXPLORE = Arg("explore", default="false", choices=("true", "false"),
              doc="with slam:=true: drive to the frontiers of the map until none is left, then save it")
#: a condition: navigating on a map, given or built
MAPPED = "$(eval map != '' or slam == 'true')"
#: a condition: navigating on a given map (map_server and amcl)
GIVEN_MAP = "$(eval map != '' and slam != 'true')"
INITIAL_POSE = Arg("initial_pose", default="",
                   doc="x,y,yaw of the robot in the map frame for amcl (empty: the world's start); with map:= only")
ENCODER_NOISE = Arg("encoder_noise", default="", choices=("", "true", "false"),
                    doc="simulate wheel encoder errors so that odometry drifts (empty: on with a map or slam, off "
                        "without)")
#: the simulator's encoder_noise argument from ENCODER_NOISE and MAP
WITH_ENCODER_NOISE = ("$(eval encoder_noise == 'true' or encoder_noise == '' and map != '' "
                      "or encoder_noise == '' and slam == 'true')")
MOVING_OBSTACLES = Arg("moving_obstacles", default="true", choices=("true", "false"),
                       doc="track moving obstacles in the lidar scans and predict them in the local planner "
                           "(move_base's obstacle_tracking.enabled and TebLocalPlannerROS.include_dynamic_obstacles); "
                           "false: every obstacle is a costmap mark, as in the lab's files")
MAX_SPEED = Arg("max_speed", default="",
                doc="top speed in m/s: every speed-dependent parameter of move_base is derived from it "
                    "(docs/reference.md §10), and above the box's 1.05 m/s a round body gets a 2 m/s drive; "
                    "empty: the parameter files' speeds")


def start_pose(world: str, initial_pose: str) -> tuple[float, float, float]:
    """Where the robot starts in the map frame: ``initial_pose`` (x,y,yaw), or the world's start when it is empty
    (a world's exported map, and a map built from the world's start, have the world's coordinates)."""
    # Only a world needs the simulator's package, which loads pybullet (and its banner on stderr).
    from simplebot_navigation.sim.starts import parse_starts
    from simplebot_navigation.sim.world_loader import load_world
    if initial_pose.strip():
        poses = parse_starts(initial_pose)
        if len(poses) != 1:
            raise ValueError(f"initial_pose:={initial_pose!r} must be one x,y,yaw")
        pose = poses[0]
    else:
        pose = load_world(world).start
    return pose.x, pose.y, pose.yaw
