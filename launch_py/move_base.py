"""The navigation side of the simplebot: the lab's move_base_local.launch on simulated time, with the
remap to the diff-drive controller's odometry and the round-body and narrow-door parameter sets.

It needs a simulator (or a robot) publishing /clock, TF, the scans and odometry on the same ROS domain.
With ``namespace:=robot1`` everything is under /robot1 and the frames are robot1/odom, robot1/base_link,
... (docs/design.md §5): the lab's files stay as they are, the frames and laser topics they name are
overridden below.
"""

from simplebot_navigation.launch.description import Arg, Group, Include, Node, Param, Remap, RosParam
from simplebot_navigation.launch.simplebot_args import (COLLISION_MONITOR, MAP, MAPPED, MAX_SPEED, MOVING_OBSTACLES,
                                                        NAMESPACE, SLAM)
from simplebot_navigation.launch.simplebot_args import TIGHT as TIGHT_ARG

CONFIG = "$(find simplebot_navigation)/config"
ROUND = "$(eval robot == 'round')"
TIGHT = "$(arg tight)"
NAMESPACED = "$(eval namespace != '')"
PREFIX = "$(arg namespace)/"
# The frames the lab's files name, per parameter of move_base; the laser sources of both costmaps.
FRAMES = {f"{costmap}/{key}": frame for costmap in ("global_costmap", "local_costmap")
          for key, frame in (("global_frame", "odom"), ("robot_base_frame", "base_link"))}
FRAMES["TebLocalPlannerROS/map_frame"] = "odom"
LASERS = {"front_laser": "front_scan", "back_laser": "back_scan"}
MONITOR = "$(arg collision_monitor)"
#: the lab's box as config/costmap_common.yaml gives it: the collision monitor reads no costmap file
BOX_FOOTPRINT = "[[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]"

LAUNCH = [
    Arg("robot", default="box", choices=("box", "round"),
        doc="robot body the parameters are for: the lab's 0.9 x 0.6 m box, or round"),
    Arg("radius", default="0.3", doc="radius of the round body in metres (robot:=round)"),
    TIGHT_ARG,
    Arg("respawn", default="true", choices=("true", "false"),
        doc="restart move_base when it exits (roslaunch's respawn)"),
    NAMESPACE,
    COLLISION_MONITOR,
    MAP,
    MAX_SPEED,
    MOVING_OBSTACLES,
    SLAM,

    Param("/use_sim_time", True),

    Group(ns="$(arg namespace)", children=[
        # The lab's TEB config reads odometry from /odom; the simulated diff-drive controller
        # publishes it on simplebot_controller/odom, as the lab's Gazebo controller did.
        Group(remaps=[Remap("/odom", "simplebot_controller/odom")], children=[
            # Its commands go to the collision monitor, or (collision_monitor:=false) straight to the base.
            Include(file="$(find simplebot_navigation)/launch_py/move_base_local.py",
                    args={"respawn": "$(arg respawn)", "cmd_vel": "cmd_vel_nav"}, if_=MONITOR),
            Include(file="$(find simplebot_navigation)/launch_py/move_base_local.py",
                    args={"respawn": "$(arg respawn)"}, unless=MONITOR),
        ]),

        # The round body: a circular footprint for both costmaps, loaded over the lab's files ...
        RosParam(file=f"{CONFIG}/round/costmap_common.yaml", ns="move_base/global_costmap", if_=ROUND),
        RosParam(file=f"{CONFIG}/round/costmap_common.yaml", ns="move_base/local_costmap", if_=ROUND),

        # Narrow doors: no padding (for either body), fine costmaps, TEB with the box outline and small
        # margins, recoveries that back up and turn where a full circle does not fit.
        RosParam(file=f"{CONFIG}/tight/costmap_common.yaml", ns="move_base/global_costmap", if_=TIGHT),
        RosParam(file=f"{CONFIG}/tight/costmap_common.yaml", ns="move_base/local_costmap", if_=TIGHT),
        RosParam(file=f"{CONFIG}/tight/costmap_global.yaml", ns="move_base/global_costmap", if_=TIGHT),
        RosParam(file=f"{CONFIG}/tight/costmap_local.yaml", ns="move_base/local_costmap", if_=TIGHT),
        RosParam(file=f"{CONFIG}/tight/teb_local_planner.yaml", ns="move_base", if_=TIGHT),
        RosParam(file=f"{CONFIG}/tight/move_base.yaml", ns="move_base", if_=TIGHT),

        # ... and TEB's circle in place of the lab's two circles or the tight set's box outline.
        RosParam(file=f"{CONFIG}/round/teb_local_planner.yaml", ns="move_base", if_=ROUND),
        # The radius of the body the simulator drives (the round files hold the default, 0.3 m).
        Param("move_base/global_costmap/robot_radius", "$(arg radius)", if_=ROUND),
        Param("move_base/local_costmap/robot_radius", "$(arg radius)", if_=ROUND),
        Param("move_base/TebLocalPlannerROS/footprint_model/radius", "$(arg radius)", if_=ROUND),

        # Moving obstacles tracked and predicted (docs/reference.md §6), over the lab's files, which predate them.
        Param("move_base/obstacle_tracking/enabled", "$(arg moving_obstacles)"),
        Param("move_base/TebLocalPlannerROS/include_dynamic_obstacles", "$(arg moving_obstacles)"),

        # In a namespace: the robot's own frames, and its lasers' topics relative to the namespace.
        *(Param(f"move_base/{name}", PREFIX + frame, if_=NAMESPACED) for name, frame in FRAMES.items()),
        *(Param(f"move_base/{costmap}/obstacles/{laser}/{key}", value, if_=NAMESPACED)
          for costmap in ("global_costmap", "local_costmap") for laser, scan in LASERS.items()
          for key, value in (("sensor_frame", f"{PREFIX}{laser}_link"), ("topic", f"{laser}/{scan}"))),

        # Navigating on a map: the global costmap in amcl's (or slam's) map frame with the map as its static layer
        # (after the namespace's frames above: the map frame is shared by all robots).
        RosParam(file=f"{CONFIG}/map/costmap_global_map.yaml", ns="move_base", if_=MAPPED),
        # ... except with a slam per robot: each robot's own map, in its namespace.
        Param("move_base/global_costmap/static_layer/map_topic", "map",
              if_="$(eval slam == 'true' and namespace != '')"),

        # The last word on every command: the scans against the body, in a process of its own.
        Node(pkg="simplebot_navigation", type="collision_monitor", name="collision_monitor", output="screen",
             respawn="$(arg respawn)", if_=MONITOR, params=[
            Param("footprint", BOX_FOOTPRINT, unless=ROUND),
            Param("robot_radius", "$(arg radius)", if_=ROUND),
            Param("base_frame", PREFIX + "base_link", if_=NAMESPACED),
            # The drive's top speed (and with it, its acceleration: docs/reference.md §5.3, §11).
            Param("max_linear_speed", "$(arg max_speed)", if_="$(eval max_speed != '')"),
        ]),
    ]),
]
