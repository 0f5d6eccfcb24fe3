"""The main() every node process shares: build the node, spin it, stop cleanly."""

from __future__ import annotations

import gc
import sys
from contextlib import contextmanager
from typing import Callable

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from simplebot_navigation.ros.executor import LeanExecutor


def run_node(label: str, build: Callable[[], Node], args=None,
             bad_input: tuple[type[BaseException], ...] = (ValueError,)) -> int:
    """Exit code 0 after Ctrl-C/SIGTERM, 2 (with one line naming what was wrong) if the node cannot be built."""
    rclpy.init(args=args if args is not None else sys.argv)
    try:
        node = build()
    except bad_input as err:
        print(f"{label}: {err}", file=sys.stderr, flush=True)
        rclpy.try_shutdown()
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):   # stopped while starting (the launch is ending)
        rclpy.try_shutdown()
        return 0
    # Start-up objects (yourdfpy's trimesh/scipy/networkx among them) live as long as the process.
    # Frozen, they drop out of Python's full collections, which otherwise stall every node for ~80 ms.
    gc.freeze()
    executor = LeanExecutor()
    executor.add_node(node)
    try:
        with stopped_by_ctrl_c():
            executor.spin()
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


class SetUpNode(Node):
    """A node whose ``_set_up`` (parameters, publishers, servers) may fail on bad input: the half-built node
    is destroyed before the error goes on, so nothing of it stays in the graph or holds a port."""

    def __init__(self, name: str, **kwargs):
        super().__init__(name, **kwargs)
        try:
            self._set_up()
        except BaseException:
            self.destroy_node()
            raise

    def _set_up(self) -> None:
        raise NotImplementedError


@contextmanager
def stopped_by_ctrl_c():
    """Ctrl-C and SIGTERM end a spin cleanly, and so does an exception from a callback that was taking its
    message while Ctrl-C shut the context down."""
    try:
        yield
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if rclpy.ok():
            raise
