"""Publishers and subscriptions without rclpy's default QoS-event handlers where they cannot help.

rclpy gives every publisher two event handlers (incompatible QoS, incompatible type) unless told
otherwise, and a Python executor walks every handler of a node each time it wakes: move_base wakes
some 300 times a second (/clock, /tf, odometry, scans, timers), and its 17 publishers' 34 handlers
were a large part of its CPU time. A mismatch is still reported where it hurts, by the
subscriber (ros2 topic echo, RViz, Foxglove, and this project's own subscriptions, which keep
their handlers), except best-effort volatile subscriptions (/clock, scans), which match every
publisher, so their incompatible-QoS handler could never fire.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy


def create_publisher(node: Node, msg_type, topic: str, qos, matched=None, **kwargs):
    """node.create_publisher with no event handler but the optional ``matched`` callback."""
    return node.create_publisher(msg_type, topic, qos, **kwargs,
                                 event_callbacks=PublisherEventCallbacks(matched=matched,
                                                                         use_default_callbacks=False))


def drop_event_handlers_of_best_effort_subscriptions(node: Node) -> None:
    """Remove the QoS-event handlers of the node's best-effort, volatile subscriptions (rclpy's /clock
    subscription among them, which cannot be created without them)."""
    for subscription in node.subscriptions:
        qos = subscription.qos_profile
        if qos.reliability != ReliabilityPolicy.BEST_EFFORT or qos.durability != DurabilityPolicy.VOLATILE:
            continue
        for handler in subscription.event_handlers:
            node.remove_waitable(handler)
            handler.destroy()
        subscription.event_handlers = []
