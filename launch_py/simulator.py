"""The simulated simplebot alone: pybullet world, lidars, diff-drive, odometry, TF and /clock.

Run it on its own where the simulation lives and ``move_base`` where the navigation runs (another
process, or another host on the same ROS domain); ``navigation`` starts both. With ``namespaces``
it simulates one robot per name in the same world (``multi_navigation``).
"""

from simplebot_navigation.launch.description import Arg, Node, Param
from simplebot_navigation.launch.simplebot_args import MAX_SPEED, RADIUS, ROBOT, RTF, WORLD

#: encoder errors with encoder_noise:=true (relative standard deviations, sim/diff_drive.py OdomNoise): a wheel
#: 1 % off in scale turns a 2 m straight line by about 2 degrees, so a lab tour drifts by metres
ENCODER_SCALE_STD = 0.01
ENCODER_SPEED_STD = 0.02

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
    Arg("encoder_noise", default="false",
        doc="wheel encoder errors (1 % scale per wheel, 2 % per-step speed noise), so that odometry drifts as a "
            "real robot's does"),
    MAX_SPEED,
    Arg("map_to_odom", default="true",
        doc="place namespaced robots' odom frames in map at their starts; false where amcl publishes map -> odom"),

    Param("/use_sim_time", True),

    Node(pkg="simplebot_navigation", type="simulator", name="simulator", output="screen",
         respawn="$(arg respawn)", params=[
        Param("world", "$(arg world)"),
        Param("robot", "$(arg robot)"),
        Param("radius", "$(arg radius)"),
        Param("max_speed", "$(arg max_speed)"),
        Param("real_time_factor", "$(arg rtf)"),
        Param("namespaces", "$(arg namespaces)"),
        Param("starts", "$(arg starts)"),
        Param("odom_scale_std", ENCODER_SCALE_STD, if_="$(arg encoder_noise)"),
        Param("odom_speed_std", ENCODER_SPEED_STD, if_="$(arg encoder_noise)"),
        Param("map_to_odom", "$(arg map_to_odom)"),
    ]),
]
