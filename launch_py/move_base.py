"""The navigation side of the simplebot: the lab's move_base_local.launch on simulated time, with the
remap to the diff-drive controller's odometry and the round-body and narrow-door parameter sets.

It needs a simulator (or a robot) publishing /clock, TF, the scans and odometry on the same ROS domain.
"""

from simplebot_navigation.launch.description import Arg, Group, Include, Param, Remap, RosParam

CONFIG = "$(find simplebot_navigation)/config"
ROUND = "$(eval robot == 'round')"
TIGHT = "$(arg tight)"

LAUNCH = [
    Arg("robot", default="box", choices=("box", "round"),
        doc="robot body the parameters are for: the lab's 0.9 x 0.6 m box, or round"),
    Arg("radius", default="0.3", doc="radius of the round body in metres (robot:=round)"),
    Arg("tight", default="false", choices=("true", "false"),
        doc="the narrow-door parameter set (config/tight/) over the lab's files"),
    Arg("respawn", default="true", choices=("true", "false"),
        doc="restart move_base when it exits (roslaunch's respawn)"),

    Param("/use_sim_time", True),

    # The lab's TEB config reads odometry from /odom; the simulated diff-drive controller
    # publishes it on /simplebot_controller/odom, as the lab's Gazebo controller did.
    Group(remaps=[Remap("/odom", "/simplebot_controller/odom")], children=[
        Include(file="$(find simplebot_navigation)/launch_py/move_base_local.py", args={"respawn": "$(arg respawn)"}),
    ]),

    # The round body: a circular footprint for both costmaps, loaded over the lab's files ...
    RosParam(file=f"{CONFIG}/round/costmap_common.yaml", ns="move_base/global_costmap", if_=ROUND),
    RosParam(file=f"{CONFIG}/round/costmap_common.yaml", ns="move_base/local_costmap", if_=ROUND),

    # Narrow doors: no padding (for either body), a fine global costmap, TEB with the box outline and
    # small margins.
    RosParam(file=f"{CONFIG}/tight/costmap_common.yaml", ns="move_base/global_costmap", if_=TIGHT),
    RosParam(file=f"{CONFIG}/tight/costmap_common.yaml", ns="move_base/local_costmap", if_=TIGHT),
    RosParam(file=f"{CONFIG}/tight/costmap_global.yaml", ns="move_base/global_costmap", if_=TIGHT),
    RosParam(file=f"{CONFIG}/tight/teb_local_planner.yaml", ns="move_base", if_=TIGHT),

    # ... and TEB's circle in place of the lab's two circles or the tight set's box outline.
    RosParam(file=f"{CONFIG}/round/teb_local_planner.yaml", ns="move_base", if_=ROUND),
    # The radius of the body the simulator drives (the round files hold the default, 0.3 m).
    Param("move_base/global_costmap/robot_radius", "$(arg radius)", if_=ROUND),
    Param("move_base/local_costmap/robot_radius", "$(arg radius)", if_=ROUND),
    Param("move_base/TebLocalPlannerROS/footprint_model/radius", "$(arg radius)", if_=ROUND),
]
