"""Call the slam node's services from a shell (ros2cli is not part of this install):

    python -m simplebot_navigation.ros.slam.slam_services save office          # office.yaml + office.pgm
    python -m simplebot_navigation.ros.slam.slam_services serialize office     # office.posegraph.npz
    python -m simplebot_navigation.ros.slam.slam_services deserialize office   # load it into the running node
                                                          [--node /slam] [--timeout 30]

Exit 0 when the node reports success; 1 with one line when it reports failure (its log says why) or does not answer
within the timeout; 2 for bad arguments.
"""

from __future__ import annotations

import math
import os
import sys
import time

import rclpy
from nav2_msgs.srv import LoadMap, SaveMap
from rclpy.executors import SingleThreadedExecutor
from rclpy.utilities import remove_ros_args

from simplebot_navigation.maps.cli import OneLineParser
from simplebot_navigation.ros.node_main import stopped_by_ctrl_c
from simplebot_navigation.ros.qos import SERVICE_QOS

PROG = "slam_services"
CALLS = {"save": (SaveMap, "save_map"), "serialize": (SaveMap, "serialize_map"),
         "deserialize": (LoadMap, "deserialize_map")}


def call(action: str, name: str, node_name: str, timeout: float, argv: list[str]) -> bool | None:
    """The service's verdict, or None when it did not answer within ``timeout`` seconds of wall time."""
    service_type, service = CALLS[action]
    request = service_type.Request(map_url=os.path.abspath(name))
    context = rclpy.Context()
    rclpy.init(args=argv, context=context)
    try:
        node = rclpy.create_node(PROG, context=context)
        client = node.create_client(service_type, f"{node_name.rstrip('/')}/{service}", qos_profile=SERVICE_QOS)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        deadline = time.monotonic() + timeout
        future = None
        with stopped_by_ctrl_c():
            while time.monotonic() < deadline and (future is None or not future.done()):
                if future is None and client.service_is_ready():
                    future = client.call_async(request)
                executor.spin_once(timeout_sec=0.05)
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()
    if future is None or not future.done():
        return None
    response = future.result()
    return bool(response.result) if service_type is SaveMap else response.result == LoadMap.Response.RESULT_SUCCESS


def main(args: list[str] | None = None) -> int:
    argv = list(sys.argv if args is None else args)
    parser = OneLineParser(prog="python -m simplebot_navigation.ros.slam.slam_services",
                           description="save the slam node's map or session, or load a session into it")
    parser.add_argument("action", choices=sorted(CALLS))
    parser.add_argument("name", help="the files' name without suffix")
    parser.add_argument("--node", default="/slam", help="the slam node (default: /slam)")
    parser.add_argument("--timeout", type=float, default=30.0, help="seconds to wait for an answer (default: 30)")
    options = parser.parse_args(remove_ros_args(argv)[1:])
    if not math.isfinite(options.timeout) or options.timeout <= 0:
        parser.error(f"--timeout: must be a positive number of seconds, got {options.timeout}")
    verdict = call(options.action, options.name, options.node, options.timeout, argv)
    if verdict is None:
        print(f"{PROG}: {options.node} did not answer within {options.timeout:g} s", file=sys.stderr)
        return 1
    if not verdict:
        print(f"{PROG}: {options.node} could not {options.action} {options.name} (its log says why)", file=sys.stderr)
        return 1
    print(f"{PROG}: {options.action} {options.name}: done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
