"""map_saver: the next map on a topic written as a map_server map (YAML + image), then exit.

    python -m simplebot_navigation.ros.map_saver_node -f office [--occ 0.65 --free 0.25 --mode trinary]
                                                      [--map-topic map] [--timeout 10]

writes office.yaml and office.pgm (office.png in scale mode) with map_saver's rules (maps/map_io.py
``save_map``, docs/reference.md §7). The subscription is reliable and transient local, so a latched map
(map_server's, a SLAM node's) arrives however long ago it was published. Exit 0 once written; 1 with one line
when no map comes within the timeout or the files cannot be written; 2 for bad arguments.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import rclpy
from nav_msgs.msg import OccupancyGrid
from rclpy.executors import SingleThreadedExecutor
from rclpy.utilities import remove_ros_args

from simplebot_navigation.maps.cli import OneLineParser
from simplebot_navigation.maps.map_io import MODES, save_map, threshold_problem
from simplebot_navigation.ros.conversions import occupancy_map_from_msg
from simplebot_navigation.ros.map_server_node import LATCHED
from simplebot_navigation.ros.node_main import stopped_by_ctrl_c

PROG = "map_saver"


def parse_arguments(argv: list[str]):
    parser = OneLineParser(prog="python -m simplebot_navigation.ros.map_saver_node",
                           description="save the next map on a topic as YAML + image")
    parser.add_argument("-f", dest="name", default="map", help="the files' name without suffix (default: map)")
    parser.add_argument("--occ", type=float, default=0.65, help="a cell of at least this (x 100) is occupied")
    parser.add_argument("--free", type=float, default=0.25, help="a cell of at most this (x 100) is free")
    parser.add_argument("--mode", choices=MODES, default="trinary", help="how cells become pixels")
    parser.add_argument("--map-topic", default="map", help="the nav_msgs/OccupancyGrid topic (default: map)")
    parser.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for a map (default: 10)")
    args = parser.parse_args(argv)
    problem = threshold_problem(args.occ, args.free)
    if problem:
        parser.error(f"{ {'occupied_thresh': '--occ', 'free_thresh': '--free'}[problem[0]]}: {problem[1]}")
    if not math.isfinite(args.timeout) or args.timeout <= 0:
        parser.error(f"--timeout: must be a positive number of seconds, got {args.timeout}")
    if not Path(args.name).parent.is_dir():
        parser.error(f"-f {args.name}: folder {Path(args.name).parent} does not exist")
    return args


def wait_for_map(topic: str, timeout: float, argv: list[str]) -> OccupancyGrid | None:
    """The first map on the topic within timeout seconds of wall time, or None."""
    context = rclpy.Context()
    rclpy.init(args=argv, context=context)
    received: list[OccupancyGrid] = []
    try:
        node = rclpy.create_node(PROG, context=context)
        node.create_subscription(OccupancyGrid, topic, received.append, LATCHED)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        deadline = time.monotonic() + timeout
        with stopped_by_ctrl_c():
            while not received and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=min(0.1, max(deadline - time.monotonic(), 0.0)))
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()
    return received[0] if received else None


def main(args: list[str] | None = None) -> int:
    argv = list(sys.argv if args is None else args)
    options = parse_arguments(remove_ros_args(argv)[1:])
    msg = wait_for_map(options.map_topic, options.timeout, argv)
    if msg is None:
        print(f"{PROG}: no map on '{options.map_topic}' within {options.timeout:g} s", file=sys.stderr)
        return 1
    yaml_path = Path(f"{options.name}.yaml")
    try:
        occupancy_map = occupancy_map_from_msg(msg)
        image = save_map(occupancy_map, yaml_path, options.mode, options.occ, options.free)
    except ValueError as err:
        print(f"{PROG}: the map on '{options.map_topic}' cannot be saved: {err}", file=sys.stderr)
        return 1
    except OSError as err:
        print(f"{PROG}: {yaml_path}: {err.strerror or err}", file=sys.stderr)
        return 1
    print(f"{PROG}: wrote {yaml_path} and {image.name}: {occupancy_map.width} x {occupancy_map.height} cells "
          f"of {occupancy_map.resolution:g} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
