"""navigation.launch: the simulated simplebot plus move_base_local.launch, all on simulated time."""

from simplebot_navigation.launch.description import Arg, Group, Include, Node, Param, Remap, RosParam

CONFIG = "$(find simplebot_navigation)/config"
ROUND = "$(eval robot == 'round')"
TIGHT = "$(arg tight)"

LAUNCH = [
    Arg("world", default="lab",
        doc="built-in world name (lab, doors, clutter, empty), forest:<seed> or a world/map YAML path"),
    Arg("robot", default="box", choices=("box", "round"), doc="robot body: the lab's 0.9 x 0.6 m box, or round"),
    Arg("radius", default="0.3", doc="radius of the round body in metres"),
    Arg("rtf", default="1.0", doc="real-time factor of the simulation (0: as fast as the nodes allow)"),
    Arg("viewer", default="false", doc="also start the browser viewer on http://127.0.0.1:8765"),
    Arg("foxglove", default="false", doc="also serve every topic to the Foxglove app over WebSocket"),
    Arg("foxglove_host", default="127.0.0.1", doc="address of the Foxglove WebSocket server (0.0.0.0: every one)"),
    Arg("foxglove_port", default="8766", doc="port of the Foxglove WebSocket server (0: a free one)"),
    Arg("tight", default="false", choices=("true", "false"),
        doc="the narrow-door parameter set (config/tight/) over the lab's files"),
    Arg("respawn", default="true", choices=("true", "false"),
        doc="restart the simulator and move_base when they exit (roslaunch's respawn)"),

    # Every node runs on the simulator's clock.
    Param("/use_sim_time", True),

    Node(pkg="simplebot_navigation", type="simulator", name="simulator", output="screen",
         respawn="$(arg respawn)", params=[
        Param("world", "$(arg world)"),
        Param("robot", "$(arg robot)"),
        Param("radius", "$(arg radius)"),
        Param("real_time_factor", "$(arg rtf)"),
    ]),

    # The lab's TEB config reads odometry from /odom; the simulated diff-drive controller
    # publishes it on /simplebot_controller/odom, as the lab's Gazebo controller did.
    Group(remaps=[Remap("/odom", "/simplebot_controller/odom")], children=[
        Include(file="$(find simplebot_navigation)/launch_py/move_base_local.py", args={"respawn": "$(arg respawn)"}),
    ]),

    # Narrow doors: no padding, a fine global costmap, TEB with the box outline and small margins.
    RosParam(file=f"{CONFIG}/tight/costmap_common.yaml", ns="move_base/global_costmap", if_=TIGHT),
    RosParam(file=f"{CONFIG}/tight/costmap_common.yaml", ns="move_base/local_costmap", if_=TIGHT),
    RosParam(file=f"{CONFIG}/tight/costmap_global.yaml", ns="move_base/global_costmap", if_=TIGHT),
    RosParam(file=f"{CONFIG}/tight/teb_local_planner.yaml", ns="move_base", if_=TIGHT),

    # The round body: a circular footprint for both costmaps and TEB, loaded over the lab's files.
    RosParam(file=f"{CONFIG}/round/costmap_common.yaml", ns="move_base/global_costmap", if_=ROUND),
    RosParam(file=f"{CONFIG}/round/costmap_common.yaml", ns="move_base/local_costmap", if_=ROUND),
    RosParam(file=f"{CONFIG}/round/teb_local_planner.yaml", ns="move_base", if_=ROUND),

    Node(pkg="simplebot_navigation", type="viewer", name="viewer", output="screen", if_="$(arg viewer)"),
    Node(pkg="simplebot_navigation", type="foxglove_bridge", name="foxglove_bridge", output="screen",
         if_="$(arg foxglove)", params=[
        Param("host", "$(arg foxglove_host)"),
        Param("port", "$(arg foxglove_port)"),
    ]),
]
