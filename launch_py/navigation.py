"""navigation.launch: the simulated simplebot plus move_base_local.launch, all on simulated time."""

from simplebot_navigation.launch.description import Arg, Include, Node, Param
from simplebot_navigation.launch.simplebot_args import COLLISION_MONITOR, NAMESPACE, RADIUS, ROBOT, RTF, TIGHT, WORLD
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
        doc="restart the simulator and move_base when they exit (roslaunch's respawn)"),
    NAMESPACE,
    COLLISION_MONITOR,

    Include(file=f"{LAUNCH_DIR}/simulator.py", args={
        "world": "$(arg world)", "robot": "$(arg robot)", "radius": "$(arg radius)", "rtf": "$(arg rtf)",
        "respawn": "$(arg respawn)", "namespaces": "$(arg namespace)"}),
    Include(file=f"{LAUNCH_DIR}/move_base.py", args={
        "robot": "$(arg robot)", "radius": "$(arg radius)", "tight": "$(arg tight)", "respawn": "$(arg respawn)",
        "namespace": "$(arg namespace)", "collision_monitor": "$(arg collision_monitor)"}),

    Node(pkg="simplebot_navigation", type="viewer", name="viewer", output="screen", if_="$(arg viewer)"),
    Node(pkg="simplebot_navigation", type="foxglove_bridge", name="foxglove_bridge", output="screen",
         if_="$(arg foxglove)", params=[
        Param("host", "$(arg foxglove_host)"),
        Param("port", "$(arg foxglove_port)"),
        Param("allowed_origins", "$(arg foxglove_allowed_origins)"),
    ]),
]
