"""The transform buffer: interpolation, chains, static vs dynamic, and tf2's three lookup errors."""

import math

import pytest
from geometry_msgs.msg import PoseStamped, TransformStamped
from rclpy.duration import Duration
from rclpy.time import Time

from simplebot_navigation.ros.tf import (Buffer, ConnectivityException, ExtrapolationException, LookupException)


def tf(parent, child, t, x=0.0, y=0.0, yaw=0.0, z=0.0):
    msg = TransformStamped()
    msg.header.frame_id = parent
    msg.child_frame_id = child
    msg.header.stamp = Time(seconds=t).to_msg()
    msg.transform.translation.x, msg.transform.translation.y, msg.transform.translation.z = x, y, z
    msg.transform.rotation.z = math.sin(yaw / 2)
    msg.transform.rotation.w = math.cos(yaw / 2)
    return msg


def xy_yaw(msg):
    r = msg.transform.rotation
    return (msg.transform.translation.x, msg.transform.translation.y,
            math.atan2(2 * (r.w * r.z + r.x * r.y), 1 - 2 * (r.y * r.y + r.z * r.z)))


@pytest.fixture
def robot():
    """odom -> base_link moving along x, base_link -> front_laser_link static, as the simulator publishes."""
    buf = Buffer()
    buf.set_transform(tf("odom", "base_link", 1.0, x=0.0), "sim")
    buf.set_transform(tf("odom", "base_link", 2.0, x=1.0, yaw=math.pi / 2), "sim")
    buf.set_transform_static(tf("base_link", "front_laser_link", 0.0, x=0.35, z=0.15), "sim")
    buf.set_transform_static(tf("base_link", "back_laser_link", 0.0, x=-0.35, yaw=math.pi, z=0.15), "sim")
    return buf


def test_linear_and_slerp_interpolation(robot):
    x, y, yaw = xy_yaw(robot.lookup_transform("odom", "base_link", Time(seconds=1.5)))
    assert x == pytest.approx(0.5) and y == pytest.approx(0.0) and yaw == pytest.approx(math.pi / 4)


def test_chain_through_a_static_edge(robot):
    x, y, yaw = xy_yaw(robot.lookup_transform("odom", "front_laser_link", Time(seconds=2.0)))
    assert (x, y, yaw) == pytest.approx((1.0, 0.35, math.pi / 2))


def test_chain_between_siblings_and_inverse(robot):
    x, y, yaw = xy_yaw(robot.lookup_transform("front_laser_link", "back_laser_link", Time()))
    assert (x, y) == pytest.approx((-0.7, 0.0), abs=1e-9) and abs(yaw) == pytest.approx(math.pi)
    x, y, yaw = xy_yaw(robot.lookup_transform("base_link", "odom", Time(seconds=2.0)))
    assert (x, y, yaw) == pytest.approx((0.0, 1.0, -math.pi / 2))


def test_time_zero_means_latest_common_time(robot):
    msg = robot.lookup_transform("odom", "front_laser_link", Time())
    assert Time.from_msg(msg.header.stamp).nanoseconds == 2_000_000_000


def test_leading_slashes_are_stripped(robot):
    x, _, _ = xy_yaw(robot.lookup_transform("/odom", "/front_laser_link", Time(seconds=1.0)))
    assert x == pytest.approx(0.35)


def test_unknown_frame_is_a_lookup_exception(robot):
    with pytest.raises(LookupException, match='"map" passed to lookupTransform argument target_frame does not exist'):
        robot.lookup_transform("map", "base_link", Time())


def test_disconnected_trees_are_a_connectivity_exception(robot):
    robot.set_transform_static(tf("map", "world", 0.0), "test")
    with pytest.raises(ConnectivityException, match="not part of the same tree"):
        robot.lookup_transform("map", "base_link", Time())


@pytest.mark.parametrize("t, word", [(3.0, "into the future"), (0.5, "into the past")])
def test_outside_the_history_is_an_extrapolation_exception(robot, t, word):
    with pytest.raises(ExtrapolationException, match=f"Lookup would require extrapolation {word}"):
        robot.lookup_transform("odom", "front_laser_link", Time(seconds=t))


def test_static_edges_answer_at_any_time(robot):
    x, _, _ = xy_yaw(robot.lookup_transform("base_link", "front_laser_link", Time(seconds=1234.0)))
    assert x == pytest.approx(0.35)


def test_can_transform_with_a_timeout_and_debug_tuple(robot):
    ok, why = robot.can_transform("odom", "base_link", Time(seconds=5.0), Duration(seconds=0.05),
                                  return_debug_tuple=True)
    assert not ok and "extrapolation into the future" in why
    assert robot.can_transform("odom", "base_link", Time(seconds=1.25))


def test_history_older_than_the_cache_is_dropped():
    buf = Buffer(cache_time=Duration(seconds=10.0))
    for t in range(0, 30):
        buf.set_transform(tf("odom", "base_link", float(t), x=float(t)), "sim")
    with pytest.raises(ExtrapolationException, match="into the past"):
        buf.lookup_transform("odom", "base_link", Time(seconds=5.0))
    assert xy_yaw(buf.lookup_transform("odom", "base_link", Time(seconds=25.5)))[0] == pytest.approx(25.5)


def test_transforms_with_nan_are_refused():
    buf = Buffer()
    assert not buf.set_transform(tf("odom", "base_link", 1.0, x=float("nan")), "sim")
    with pytest.raises(LookupException):
        buf.lookup_transform("odom", "base_link", Time())


def test_transform_pose(robot):
    pose = PoseStamped()
    pose.header.frame_id = "base_link"
    pose.header.stamp = Time(seconds=2.0).to_msg()
    pose.pose.position.x = 1.0
    pose.pose.orientation.w = 1.0
    out = robot.transform_pose(pose, "odom")
    assert (out.pose.position.x, out.pose.position.y) == pytest.approx((1.0, 1.0))
    assert out.header.frame_id == "odom"


def test_a_backward_jump_of_the_node_clock_clears_dynamic_transforms_and_keeps_static_ones(context):
    """A restarted simulator: the old history would make every new transform 'extrapolation into the past'."""
    from rclpy.node import Node

    node = Node("tf_jump", context=context)
    try:
        clock = node.get_clock()
        clock._set_ros_time_is_active(True)
        clock.set_ros_time_override(Time(seconds=60.0))
        buf = Buffer(node=node)
        buf.set_transform(tf("odom", "base_link", 59.0, x=5.0), "sim")
        buf.set_transform(tf("odom", "base_link", 60.0, x=6.0), "sim")
        buf.set_transform_static(tf("base_link", "front_laser_link", 0.0, x=0.35), "sim")
        assert buf.can_transform("odom", "base_link", Time(seconds=59.5))

        clock.set_ros_time_override(Time(seconds=0.5))           # the simulator starts again
        assert not buf.can_transform("odom", "base_link", Time())
        buf.set_transform(tf("odom", "base_link", 0.5, x=0.1), "sim")
        buf.set_transform(tf("odom", "base_link", 0.6, x=0.2), "sim")
        assert xy_yaw(buf.lookup_transform("odom", "base_link", Time(seconds=0.55)))[0] == pytest.approx(0.15)
        laser = buf.lookup_transform("base_link", "front_laser_link", Time())
        assert laser.transform.translation.x == pytest.approx(0.35)

        clock.set_ros_time_override(Time(seconds=0.7))           # forward: nothing is cleared
        assert buf.can_transform("odom", "base_link", Time(seconds=0.55))
    finally:
        node.destroy_node()
