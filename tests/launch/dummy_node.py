"""A node for launcher tests: prints its parameters, then exits after `exit_after` s with `exit_code`."""

import sys
import time

import rclpy
from rclpy.node import Node


def main() -> None:
    rclpy.init(args=sys.argv)
    node = Node("dummy")
    node.declare_parameter("exit_after", 0.0)
    node.declare_parameter("exit_code", 0)
    node.declare_parameter("greeting", "hello")
    exit_after = node.get_parameter("exit_after").value
    print(f"{node.get_fully_qualified_name()} says {node.get_parameter('greeting').value}", flush=True)
    start = time.monotonic()
    try:
        while rclpy.ok() and (exit_after <= 0 or time.monotonic() - start < exit_after):
            rclpy.spin_once(node, timeout_sec=0.05)
    except KeyboardInterrupt:
        print("interrupted, shutting down", flush=True)
        sys.exit(0)
    sys.exit(node.get_parameter("exit_code").value)


if __name__ == "__main__":
    main()
