"""map_server: one map from a map_server YAML file (maps/map_io.py, docs/reference.md §7), latched on ``map`` and
``map_metadata`` and served by nav_msgs/GetMap on ``map_server/map``.

    python -m simplebot_navigation.ros.map_server_node office.yaml [--ros-args -p frame_id:=map]

The file is the parameter ``yaml_filename`` (Nav2's name) or the first argument (as ROS 1's ``rosrun map_server
map_server office.yaml``), the argument winning. A world's name instead of a file (``lab``, ``forest:3``) serves
that world's map, exported at WORLD_MAP_RESOLUTION (sim/map_export.py), so a simulated world needs no map file. A bad map at start is one line naming the file and the key, and
exit code 2. Setting ``yaml_filename`` (or ``frame_id``) while running loads the new map in full first: a bad
one is refused with the reason, and the old map stays served.
"""

from __future__ import annotations

import dataclasses
import sys

from nav_msgs.msg import MapMetaData, OccupancyGrid
from nav_msgs.srv import GetMap
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from simplebot_description import world_name_problem
from simplebot_navigation.maps.map_io import OccupancyMap, load_map
from simplebot_navigation.parameters.spec import Param
from simplebot_navigation.ros.conversions import occupancy_map_msg
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.ros.params import descriptor, refuse_unknown_parameters
from simplebot_navigation.ros.publishers import create_publisher
from simplebot_navigation.ros.qos import LATCHED, SERVICE_QOS

#: metres per cell of a world's map served by name
WORLD_MAP_RESOLUTION = 0.05
PARAMETERS = {
    "yaml_filename": Param(str, "", "", "the map's YAML file (map_server format), or a world's name whose map is "
                           "exported; setting it loads that map"),
    "frame_id": Param(str, "map", "", "the frame the published map is stamped with"),
}


class MapServerNode(SetUpNode):
    def __init__(self, **kwargs):
        super().__init__("map_server", **kwargs)

    def _set_up(self) -> None:
        values = {name: spec.check(self.declare_parameter(name, spec.default, descriptor(spec)).value,
                                   f"map_server parameter '{name}'") for name, spec in PARAMETERS.items()}
        self.map = self._load(**values)
        self.map_pub = create_publisher(self, OccupancyGrid, "map", LATCHED)
        self.metadata_pub = create_publisher(self, MapMetaData, "map_metadata", LATCHED)
        self.create_service(GetMap, "~/map", self._on_get_map, qos_profile=SERVICE_QOS)
        refuse_unknown_parameters(self)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._publish(values["yaml_filename"])

    @staticmethod
    def _load(yaml_filename: str, frame_id: str, loaded: OccupancyMap | None = None) -> OccupancyMap:
        """The map of the file, in the frame (``loaded``: this file's map, read already)."""
        if not yaml_filename:
            raise ValueError("parameter 'yaml_filename' is empty: give the map's YAML file "
                             "(-p yaml_filename:=office.yaml, or as the first argument)")
        frame = frame_id.lstrip("/")
        if not frame:
            raise ValueError(f"parameter 'frame_id': expected a frame name, got {frame_id!r}")
        return dataclasses.replace(loaded or read_map(yaml_filename), frame_id=frame)

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """A new file or frame is loaded in full before it is taken; if anything is wrong, nothing changes."""
        ours = [p for p in params if p.name in PARAMETERS]
        if not ours:
            return SetParametersResult(successful=True)
        values = {name: self.get_parameter(name).value for name in PARAMETERS}
        try:
            for param in ours:
                values[param.name] = PARAMETERS[param.name].check(param.value, f"map_server parameter '{param.name}'")
            same_file = not any(p.name == "yaml_filename" for p in ours)
            new_map = self._load(**values, loaded=self.map if same_file else None)
        except ValueError as err:
            self.get_logger().warn(f"refused: {err}; still serving {self.get_parameter('yaml_filename').value}")
            return SetParametersResult(successful=False, reason=str(err))
        self.map = new_map
        self._publish(values["yaml_filename"])
        return SetParametersResult(successful=True)

    def _publish(self, yaml_filename: str) -> None:
        self._msg = occupancy_map_msg(self.map, self.get_clock().now().to_msg())
        self.map_pub.publish(self._msg)
        self.metadata_pub.publish(self._msg.info)
        x, y, yaw = self.map.origin
        self.get_logger().info(f"{yaml_filename}: {self.map.width} x {self.map.height} cells of "
                               f"{self.map.resolution:g} m, origin ({x:g}, {y:g}, {yaw:g}), frame {self.map.frame_id}")

    def _on_get_map(self, _request: GetMap.Request, response: GetMap.Response) -> GetMap.Response:
        response.map = self._msg
        return response


def read_map(source: str) -> OccupancyMap:
    """A map YAML file, or the exported map of the world named ``source``."""
    if source.lower().endswith((".yaml", ".yml")):
        return load_map(source)
    problem = world_name_problem(source)
    if problem:
        raise ValueError(f"parameter 'yaml_filename': {source!r} is neither a map YAML file nor a world: {problem}")
    # Only a world needs the simulator's package, which loads pybullet (and its banner on stderr).
    from simplebot_navigation.sim.map_export import export_map
    from simplebot_navigation.sim.world_loader import load_world
    return export_map(load_world(source), WORLD_MAP_RESOLUTION)


def file_argument(argv: list[str]) -> list[Parameter]:
    """The parameter override the command line's first argument makes (none without one); ValueError for more."""
    arguments = remove_ros_args(argv)[1:]
    if len(arguments) > 1:
        raise ValueError(f"one map YAML file at most, got {' '.join(arguments)}")
    return [Parameter("yaml_filename", value=arguments[0])] if arguments else []


def main(args: list[str] | None = None) -> int:
    argv = list(sys.argv if args is None else args)
    try:
        overrides = file_argument(argv)
    except ValueError as err:
        print(f"map_server: {err}", file=sys.stderr)
        return 2
    return run_node("map_server", lambda: MapServerNode(parameter_overrides=overrides), argv)


if __name__ == "__main__":
    sys.exit(main())
