"""The interface packages we build are those of ROS 2 Jazzy: same fields, same type hash."""

import rclpy
from rclpy.node import Node

JAZZY_TFMESSAGE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


def test_tfmessage_type_hash_is_jazzys():
    from tf2_msgs.msg import TFMessage
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = Node("hash_probe", context=context)
        node.create_publisher(TFMessage, "/hash_probe_tf", 1)
        infos = node.get_publishers_info_by_topic("/hash_probe_tf")
        assert infos and str(infos[0].topic_type_hash) == JAZZY_TFMESSAGE_HASH
        assert infos[0].topic_type == "tf2_msgs/msg/TFMessage"
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_map_msgs_and_move_base_msgs_fields():
    from map_msgs.msg import OccupancyGridUpdate
    from move_base_msgs.action import MoveBase
    assert OccupancyGridUpdate.get_fields_and_field_types() == {
        "header": "std_msgs/Header", "x": "int32", "y": "int32", "width": "uint32", "height": "uint32",
        "data": "sequence<int8>"}
    assert MoveBase.Goal.get_fields_and_field_types() == {"target_pose": "geometry_msgs/PoseStamped"}
    assert MoveBase.Feedback.get_fields_and_field_types() == {"base_position": "geometry_msgs/PoseStamped"}
    assert MoveBase.Result.get_fields_and_field_types() == {}


def test_costmap_converter_msgs_fields():
    from costmap_converter_msgs.msg import ObstacleArrayMsg, ObstacleMsg
    assert ObstacleMsg.get_fields_and_field_types() == {
        "header": "std_msgs/Header", "polygon": "geometry_msgs/Polygon", "radius": "double", "id": "int64",
        "orientation": "geometry_msgs/Quaternion", "velocities": "geometry_msgs/TwistWithCovariance"}
    assert ObstacleArrayMsg.get_fields_and_field_types() == {
        "header": "std_msgs/Header", "obstacles": "sequence<costmap_converter_msgs/ObstacleMsg>"}
