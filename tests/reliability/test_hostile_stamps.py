"""Stamps no sensor or TF publisher should send: one message must neither stop the costmap's node
nor poison the transforms it keeps."""

from builtin_interfaces.msg import Time as TimeMsg
from rclpy.time import Time

from tests.ros.test_costmap_ros import FRONT_X, lab, transform  # noqa: F401  (lab is a fixture)


def wall_marked(costmap) -> bool:
    with costmap.lock:
        master = costmap.costmap
        return master.get_cost(*master.world_to_map(FRONT_X, 0.0)) == 254


def test_a_scan_with_a_negative_stamp_is_dropped_and_the_node_keeps_running(lab, capfd):
    fake = lab()
    costmap = fake.costmap("local_costmap")
    fake.spin_until(lambda: wall_marked(costmap), what="the wall marked")
    bad = fake.scan("front_laser_link", TimeMsg(sec=-1, nanosec=0))
    fake.scan_pubs["front_laser_link"].publish(bad)
    fake.spin_for(0.5)                       # an exception from a callback would escape spin here
    assert "Discarding message from [/front_laser/front_scan]: header.stamp.sec -1 is negative" \
        in capfd.readouterr().err
    with costmap.lock:
        costmap.reset_layers()
    fake.spin_until(lambda: wall_marked(costmap), what="the wall marked again from good scans")
    assert costmap.get_robot_pose() is not None


def test_a_transform_from_the_far_future_does_not_evict_the_real_ones(lab, capfd):
    fake = lab()
    costmap = fake.costmap("local_costmap")
    fake.spin_until(lambda: costmap.get_robot_pose() is not None, what="the robot pose")
    future = Time(nanoseconds=fake.robot.get_clock().now().nanoseconds + 10**15).to_msg()
    fake.tf_pub.send_transform(transform("odom", "base_link", future, 5.0, 5.0, 0.0))
    negative = TimeMsg(sec=-5, nanosec=0)
    fake.tf_pub.send_transform(transform("odom", "base_link", negative, 5.0, 5.0, 0.0))
    fake.spin_for(0.5)
    err = capfd.readouterr().err
    assert "ignoring transform 'odom' -> 'base_link' from /tf: its stamp is" in err
    assert "ahead of this node's clock" in err
    fake.spin_for(0.3)
    # The pose is the real one, not the hostile (5, 5). (On a loaded machine a tick can come later than
    # transform_tolerance, so the pose may be missing for a moment: wait for it, then look.)
    poses = []
    fake.spin_until(lambda: poses.append(costmap.get_robot_pose()) or poses[-1] is not None, what="the robot pose")
    assert abs(poses[-1].x) < 1e-9 and abs(poses[-1].y) < 1e-9, poses[-1]
