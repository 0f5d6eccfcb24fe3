"""The simulated simplebot alone: pybullet world, lidars, diff-drive, odometry, TF and /clock.

Run it on its own where the simulation lives and ``move_base`` where the navigation runs (another
process, or another host on the same ROS domain); ``navigation`` starts both. With ``namespaces``
it simulates one robot per name in the same world (``multi_navigation``).
"""

from simplebot_navigation.launch.description import Arg, Node, Param
from simplebot_navigation.launch.simplebot_args import RADIUS, ROBOT, RTF, WORLD

LAUNCH = [
    WORLD,
    ROBOT,
    RADIUS,
    RTF,
    Arg("respawn", default="true", choices=("true", "false"),
        doc="restart the simulator when it exits (roslaunch's respawn)"),
    Arg("namespaces", default="",
        doc="one robot per space-separated namespace (robot1 robot2); empty: one robot without a namespace"),
    Arg("starts", default="", doc="x,y,yaw;x,y,yaw;... per robot (empty: the world's starts, or its start)"),

    Param("/use_sim_time", True),

    Node(pkg="simplebot_navigation", type="simulator", name="simulator", output="screen",
         respawn="$(arg respawn)", params=[
        Param("world", "$(arg world)"),
        Param("robot", "$(arg robot)"),
        Param("radius", "$(arg radius)"),
        Param("real_time_factor", "$(arg rtf)"),
        Param("namespaces", "$(arg namespaces)"),
        Param("starts", "$(arg starts)"),
    ]),
]
