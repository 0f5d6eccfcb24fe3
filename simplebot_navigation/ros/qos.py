"""QoS profiles the nodes share: one definition, so a latched topic or a burst-proof service means the same
everywhere."""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

#: a topic whose last message a late subscriber still gets (ROS 1's latched topics: maps, descriptions)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: requests a burst may queue on a service (an action's goal, cancel and result services among them) before the
#: middleware drops them: the default service profile keeps 10; ROS 1 actionlib queued 50 goals
SERVICE_QOS = QoSProfile(depth=50, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
