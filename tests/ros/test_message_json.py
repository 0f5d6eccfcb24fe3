"""JSON from a Foxglove client to a ROS message: every field checked against its type, errors name the field."""

import pytest
from geometry_msgs.msg import PointStamped, PoseStamped, PoseWithCovarianceStamped
from rclpy.serialization import deserialize_message, serialize_message

from simplebot_navigation.ros.tools.message_json import message_from_json


def test_a_pose_estimate_as_the_app_writes_it():
    text = ('{"header": {"stamp": {"sec": 12, "nsec": 500}, "frame_id": "odom"},'
            ' "pose": {"pose": {"position": {"x": 1, "y": -2.5}, "orientation": {"z": 0.6, "w": 0.8}},'
            ' "covariance": [' + ", ".join(["0.25"] * 36) + "]}}")
    msg = message_from_json(PoseWithCovarianceStamped, text.encode())
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (12, 500, "odom")
    pose = msg.pose.pose
    assert (pose.position.x, pose.position.y, pose.position.z) == (1.0, -2.5, 0.0)   # left out: the default
    assert (pose.orientation.z, pose.orientation.w) == (0.6, 0.8)
    assert list(msg.pose.covariance) == [0.25] * 36
    assert deserialize_message(serialize_message(msg), PoseWithCovarianceStamped) == msg


@pytest.mark.parametrize("msg_class, text, error", [
    (PoseStamped, b"\xff\xfe", "not JSON"),
    (PoseStamped, b"{'single': 'quotes'}", "not JSON"),
    (PoseStamped, b"[1, 2]", "the message must be an object, got list"),
    (PoseStamped, b'{"pose": 3}', "pose must be an object, got int"),
    (PoseStamped, b'{"pose": {"position": {"x": "far"}}}', "pose.position.x must be of type double, got str"),
    (PoseStamped, b'{"pose": {"position": {"x": true}}}', "pose.position.x must be of type double, got bool"),
    (PoseStamped, b'{"pose": {"position": {"x": null}}}', "pose.position.x must be of type double, got null"),
    (PoseStamped, b'{"header": {"frame_id": 7}}', "header.frame_id must be of type string, got int"),
    (PoseStamped, b'{"header": {"stamp": {"sec": 1.5}}}', "header.stamp.sec must be of type int32, got float"),
    (PoseStamped, b'{"header": {"stamp": {"sec": 4294967296}}}', "header.stamp.sec = 4294967296 is out of range"),
    (PoseStamped, b'{"header": {"stamp": {"nanosec": -1}}}', r"header.stamp.nanosec = -1 is out of range for uint32"),
    (PoseStamped, b'{"pose": {"postion": {}}}', "pose.postion: Pose has no such field"),
    (PointStamped, b'{"point": {"x": 1, "w": 2}}', "point.w: Point has no such field"),
    (PoseWithCovarianceStamped, b'{"pose": {"covariance": [1, 2]}}', "pose.covariance must have 36 elements, got 2"),
    (PoseWithCovarianceStamped, b'{"pose": {"covariance": 1}}', "pose.covariance must be an array, got int"),
])
def test_bad_values_are_named(msg_class, text, error):
    with pytest.raises(ValueError, match=error):
        message_from_json(msg_class, text)
