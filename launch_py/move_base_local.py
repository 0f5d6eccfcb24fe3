"""move_base_local.launch of the lab: move_base with the lab's costmap and planner configuration."""

from simplebot_navigation.launch.description import Arg, Node, Remap, RosParam

CONFIG = "$(find simplebot_navigation)/config"

LAUNCH = [
    Arg("respawn", default="false", choices=("true", "false"),
        doc="restart move_base when it exits (the lab's file: false)"),
    Arg("cmd_vel", default="simplebot_controller/cmd_vel",
        doc="where move_base's velocity commands go (the lab's file: the robot controller)"),

    # The main node that starts the navigation stack
    Node(pkg="move_base", type="move_base", name="move_base", output="screen", respawn="$(arg respawn)", params=[
        # common configuration for both global and local costmaps
        RosParam(file=f"{CONFIG}/costmap_common.yaml", command="load", ns="global_costmap"),
        RosParam(file=f"{CONFIG}/costmap_common.yaml", command="load", ns="local_costmap"),
        # the configuration that is separate for the global and local cost maps
        RosParam(file=f"{CONFIG}/costmap_global_odom.yaml", command="load"),
        RosParam(file=f"{CONFIG}/costmap_local.yaml", command="load"),
        # the configuration of the planners
        RosParam(file=f"{CONFIG}/teb_local_planner.yaml", command="load"),
        RosParam(file=f"{CONFIG}/global_planner.yaml", command="load"),
    ], remaps=[
        # The velocity command that is sent to the robot controller (relative: /simplebot_controller/cmd_vel
        # at the root, /robot1/simplebot_controller/cmd_vel for a move_base in namespace robot1)
        Remap("cmd_vel", "$(arg cmd_vel)"),
    ]),
]
