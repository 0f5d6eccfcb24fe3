"""The launch arguments of the simplebot's launch files, declared once here.

As in roslaunch every file declares the arguments it takes (an included file gets only those), so
launch_py/navigation.py, simulator.py, move_base.py and multi_navigation.py list these same objects.
"""

from simplebot_navigation.launch.description import Arg

WORLD = Arg("world", default="lab",
            doc="built-in world name (lab, doors, clutter, empty), forest:<seed> or a world/map YAML path")
ROBOT = Arg("robot", default="box", choices=("box", "round"), doc="robot body: the lab's 0.9 x 0.6 m box, or round")
RADIUS = Arg("radius", default="0.3", doc="radius of the round body in metres")
RTF = Arg("rtf", default="1.0", doc="real-time factor of the simulation (0: as fast as the nodes allow)")
TIGHT = Arg("tight", default="false", choices=("true", "false"),
            doc="the narrow-door parameter set (config/tight/) over the lab's files")
