"""navigation.launch: the simulated simplebot plus move_base_local.launch, all on simulated time.

With ``map:=office.yaml`` (or a world's name, whose map is exported) it navigates on a map: map_server and amcl
start, the global costmap is in ``map`` with the map as its static layer, and the encoders drift.
"""

from simplebot_navigation.launch.description import Arg, Include, Node, Param
from simplebot_navigation.launch.simplebot_args import (COLLISION_MONITOR, ENCODER_NOISE, EXPLORE, GIVEN_MAP,
                                                        INITIAL_POSE, MAP, MAPPED, MAX_SPEED, MOVING_OBSTACLES,
                                                        NAMESPACE, RADIUS, ROBOT, RTF, SLAM, TIGHT,
                                                        WITH_ENCODER_NOISE, WORLD)
from simplebot_navigation.web_host import FOXGLOVE_ALLOWED_ORIGINS

LAUNCH_DIR = "$(find simplebot_navigation)/launch_py"


LAUNCH = [
    WORLD,
    ROBOT,
    RADIUS,
    RTF,
    Arg("viewer", default="false", doc="also start the browser viewer on http://127.0.0.1:8765"),
    Arg("foxglove", default="false", doc="also serve every topic to the Foxglove app over WebSocket"),
    Arg("foxglove_host", default="127.0.0.1", doc="address of the Foxglove WebSocket server (0.0.0.0: every one)"),
    Arg("foxglove_port", default="8766", doc="port of the Foxglove WebSocket server (0: a free one)"),
    Arg("foxglove_allowed_origins", default=" ".join(FOXGLOVE_ALLOWED_ORIGINS),
        doc="browser pages (origins, space-separated) that may connect to the Foxglove server; a client that sends "
            "no Origin (not a browser) always may"),
    TIGHT,
    Arg("respawn", default="true", choices=("true", "false"),
        doc="restart the nodes when they exit (roslaunch's respawn): the simulator, move_base, the collision monitor, "
            "map_server and amcl, the viewer and the Foxglove bridge"),
    NAMESPACE,
    COLLISION_MONITOR,
    MAP,
    INITIAL_POSE,
    ENCODER_NOISE,
    MAX_SPEED,
    MOVING_OBSTACLES,
    SLAM,
    EXPLORE,

    Include(file=f"{LAUNCH_DIR}/simulator.py", args={
        "world": "$(arg world)", "robot": "$(arg robot)", "radius": "$(arg radius)", "rtf": "$(arg rtf)",
        "respawn": "$(arg respawn)", "namespaces": "$(arg namespace)", "encoder_noise": WITH_ENCODER_NOISE,
        "map_to_odom": "$(eval map == '' and slam != 'true')", "max_speed": "$(arg max_speed)"}),
    Include(file=f"{LAUNCH_DIR}/move_base.py", args={
        "robot": "$(arg robot)", "radius": "$(arg radius)", "tight": "$(arg tight)", "respawn": "$(arg respawn)",
        "namespace": "$(arg namespace)", "collision_monitor": "$(arg collision_monitor)", "map": "$(arg map)",
        "max_speed": "$(arg max_speed)", "moving_obstacles": "$(arg moving_obstacles)", "slam": "$(arg slam)"}),

    # Navigation on a map: the map_server's map and amcl on it.
    Node(pkg="map_server", type="map_server", name="map_server", output="screen", respawn="$(arg respawn)",
         if_=GIVEN_MAP, params=[Param("yaml_filename", "$(arg map)")]),
    Include(file=f"{LAUNCH_DIR}/amcl.py", if_=GIVEN_MAP, args={
        "world": "$(arg world)", "namespace": "$(arg namespace)", "initial_pose": "$(arg initial_pose)",
        "respawn": "$(arg respawn)"}),

    # Or the map built while driving, and the frontiers driven to.
    Include(file=f"{LAUNCH_DIR}/slam.py", if_="$(arg slam)", args={
        "world": "$(arg world)", "namespace": "$(arg namespace)", "initial_pose": "$(arg initial_pose)",
        "explore": "$(arg explore)", "respawn": "$(arg respawn)"}),

    Node(pkg="simplebot_navigation", type="viewer", name="viewer", output="screen", respawn="$(arg respawn)",
         if_="$(arg viewer)", params=[
        Param("fixed_frame", "map", if_=MAPPED),
    ]),
    Node(pkg="simplebot_navigation", type="foxglove_bridge", name="foxglove_bridge", output="screen",
         respawn="$(arg respawn)", if_="$(arg foxglove)", params=[
        Param("host", "$(arg foxglove_host)"),
        Param("port", "$(arg foxglove_port)"),
        Param("allowed_origins", "$(arg foxglove_allowed_origins)"),
    ]),
]
