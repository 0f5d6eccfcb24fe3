"""The lifecycle state a Nav2 client waits for (``<name>/get_state``), on nodes that are not lifecycle nodes.

move_base and amcl run from start to exit: they answer ``active`` once they are ready and ``inactive`` before,
and refuse every transition (``<name>/change_state``) with a logged reason. Nav2's scripts only read the state
(nav2_simple_commander's waitUntilNav2Active); a manager that tries to configure or shut them down learns
that it cannot.
"""

from __future__ import annotations

from typing import Callable

from lifecycle_msgs.msg import State
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.node import Node

from simplebot_navigation.ros.qos import SERVICE_QOS


def serve_lifecycle_state(node: Node, name: str, is_active: Callable[[], bool]) -> None:
    """``name``/get_state and ``name``/change_state (names relative to the node's namespace, or ``~`` for the
    node's own) answering for ``node``."""

    def get_state(_request, response):
        if is_active():
            response.current_state = State(id=State.PRIMARY_STATE_ACTIVE, label="active")
        else:
            response.current_state = State(id=State.PRIMARY_STATE_INACTIVE, label="inactive")
        return response

    def change_state(request, response):
        transition = f"{request.transition.id} ({request.transition.label or 'no label'})"
        node.get_logger().error(
            f"{node.resolve_service_name(f'{name}/change_state')}: transition {transition} "
            f"refused: {node.get_name()} is not a lifecycle node; it is active from start to exit, stop or restart "
            "its process instead")
        response.success = False
        return response

    node.create_service(GetState, f"{name}/get_state", get_state, qos_profile=SERVICE_QOS)
    node.create_service(ChangeState, f"{name}/change_state", change_state, qos_profile=SERVICE_QOS)
