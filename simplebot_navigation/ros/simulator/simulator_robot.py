"""One simulated robot's topics and frames: odometry, ground truth, scans, collisions, cmd_vel and its TF.

A robot without a namespace has the lab's names (/simplebot_controller/odom, odom -> base_link). A robot
in namespace ``robot1`` has them under /robot1 and its frames prefixed (robot1/odom -> robot1/base_link),
on the shared /tf and /tf_static, and a static ``map`` -> robot1/odom transform at its start pose, so
that all robots appear in one fixed frame (docs/design.md §5).
"""

from __future__ import annotations

import array

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import TransformStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from simplebot_navigation.geometry import axis_angle_to_quaternion, compose, rpy_to_quaternion, yaw_to_quaternion
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.sim.simulator import SimplebotSim

#: the fixed frame at the world's origin that namespaced robots' odom frames hang from
MAP_FRAME = "map"


def set_stamp(stamp, t: float) -> None:
    """Write t seconds into a builtin_interfaces/Time in place (messages are reused every step)."""
    stamp.sec, stamp.nanosec = divmod(round(t * 1e9), 1_000_000_000)


def transform(parent: str, child: str, xyz=(0.0, 0.0, 0.0), quat=(0.0, 0.0, 0.0, 1.0)) -> TransformStamped:
    tf = TransformStamped()
    tf.header.frame_id = parent
    tf.child_frame_id = child
    set_transform(tf, (*xyz, *quat))
    return tf


def set_transform(tf: TransformStamped, value) -> None:
    """value: (x, y, z, qx, qy, qz, qw)."""
    t, r = tf.transform.translation, tf.transform.rotation
    t.x, t.y, t.z, r.x, r.y, r.z, r.w = (float(v) for v in value)


def _odometry_msg(frame_id: str, child_frame_id: str) -> Odometry:
    msg = Odometry()
    msg.header.frame_id = frame_id
    msg.child_frame_id = child_frame_id
    return msg


class SimulatedRobotIO:
    """Publishers, the cmd_vel subscription and reusable messages of robot ``index`` of the simulation.

    ``wheel_joints`` is joint -> (parent, child, origin (x, y, z, qx, qy, qz, qw), unit axis), from the URDF.
    """

    def __init__(self, node: Node, sim: SimplebotSim, index: int, namespace: str, wheel_joints: dict):
        self.node, self.sim, self.index, self.namespace = node, sim, index, namespace
        self.prefix = f"{namespace}/" if namespace else ""
        description = sim.description
        self.odom_pub = node.create_publisher(Odometry, self.topic("simplebot_controller/odom"), 10)
        self.truth_pub = node.create_publisher(Odometry, self.topic("simplebot/ground_truth"), 10)
        self.collision_pub = node.create_publisher(DiagnosticStatus, self.topic("simplebot/collisions"), LATCHED)
        self.scan_pubs = {frame: node.create_publisher(LaserScan, self.topic(scan.topic), qos_profile_sensor_data)
                          for frame, scan in description.scans.items()}
        self.cmd_vel_topic = self.topic("simplebot_controller/cmd_vel")
        node.create_subscription(Twist, self.cmd_vel_topic, self._on_cmd_vel, 10)
        node.create_publisher(String, self.topic("robot_description"), LATCHED).publish(
            String(data=description.urdf))

        # Messages are built once and refilled: constructing them costs more than a physics step.
        odom, truth = sim.odometry(index), sim.ground_truth(index)
        # Ground truth is in the world frame, which belongs to no robot.
        self._odom_msgs = [(self.odom_pub, _odometry_msg(self.frame(odom.frame_id), self.frame(odom.child_frame_id))),
                           (self.truth_pub, _odometry_msg(truth.frame_id, self.frame(truth.child_frame_id)))]
        self._odom_tf = transform(self.frame(odom.frame_id), self.frame(odom.child_frame_id))
        self._wheel_joints = wheel_joints
        self._wheel_tfs = {name: transform(self.frame(parent), self.frame(child))
                           for name, (parent, child, _, _) in wheel_joints.items()}
        self._scan_msgs = {frame: LaserScan() for frame in self.scan_pubs}
        self._reported_collisions = -1
        self.publish_collisions()

    def topic(self, name: str) -> str:
        return "/" + "/".join(part for part in (self.namespace, name.lstrip("/")) if part)

    def frame(self, name: str) -> str:
        return self.prefix + name

    def static_transforms(self, map_to_odom: bool = True) -> list[TransformStamped]:
        """The URDF's fixed joints and, for a namespaced robot unless a localizer owns it, map -> its odom at the
        start pose."""
        joints = [transform(self.frame(j.parent), self.frame(j.child), j.xyz, rpy_to_quaternion(j.rpy))
                  for j in self.sim.description.fixed_joints]
        if not self.namespace or not map_to_odom:
            return joints
        start = self.sim.robots[self.index].start
        return joints + [transform(MAP_FRAME, self._odom_tf.header.frame_id, (start.x, start.y, 0.0),
                                   yaw_to_quaternion(start.yaw))]

    # -- publishing -----------------------------------------------------------------------------
    def publish_odometry(self, stamp, dropout: bool) -> list[TransformStamped]:
        """Odometry and ground truth (odometry not while ``dropout``); returns the transforms to send."""
        odom = self.sim.odometry(self.index)
        for source, (pub, msg) in zip((odom, self.sim.ground_truth(self.index)), self._odom_msgs):
            if dropout and pub is self.odom_pub:
                continue
            msg.header.stamp = stamp
            pose, twist = msg.pose.pose, msg.twist.twist
            pose.position.x, pose.position.y = source.x, source.y
            _, _, pose.orientation.z, pose.orientation.w = yaw_to_quaternion(source.yaw)
            twist.linear.x, twist.linear.y, twist.angular.z = source.vx, source.vy, source.wz
            pub.publish(msg)
        self._odom_tf.header.stamp = stamp
        set_transform(self._odom_tf, (odom.x, odom.y, 0.0, *yaw_to_quaternion(odom.yaw)))
        transforms = [] if dropout else [self._odom_tf]
        joints = self.sim.joint_states(self.index)
        for name, angle in zip(joints.names, joints.positions):
            _, _, origin, axis = self._wheel_joints[name]
            tf = self._wheel_tfs[name]
            tf.header.stamp = stamp
            set_transform(tf, compose(origin, (0.0, 0.0, 0.0, *axis_angle_to_quaternion(axis, angle))))
            transforms.append(tf)
        return transforms

    def publish_scans(self, dropped) -> None:
        for scan in self.sim.due_scans(self.index):
            if not dropped(scan.frame):
                self.scan_pubs[scan.frame].publish(self._scan_msg(scan))

    def _scan_msg(self, scan) -> LaserScan:
        msg = self._scan_msgs[scan.frame]
        set_stamp(msg.header.stamp, scan.stamp)
        msg.header.frame_id = self.frame(scan.frame)
        msg.angle_min, msg.angle_max, msg.angle_increment = scan.angle_min, scan.angle_max, scan.angle_increment
        msg.time_increment, msg.scan_time = scan.time_increment, scan.scan_time
        msg.range_min, msg.range_max = scan.range_min, scan.range_max
        ranges = array.array("f")
        ranges.frombytes(scan.ranges.astype(np.float32, copy=False).tobytes())
        msg.ranges = ranges
        return msg

    def publish_collisions_if_new(self) -> None:
        if self.sim.collisions(self.index).count != self._reported_collisions:
            self.publish_collisions()

    def publish_collisions(self) -> None:
        report = self.sim.collisions(self.index)
        self._reported_collisions = report.count
        status = DiagnosticStatus(name=self.topic("simplebot/collisions").lstrip("/"),
                                  hardware_id=self.namespace or "simplebot",
                                  level=DiagnosticStatus.WARN if report.count else DiagnosticStatus.OK,
                                  message=f"{report.count} collision(s): {report.count_moving} while moving, "
                                          f"struck {report.count_standing} time(s) while standing")
        values = {"count": report.count, "count_moving": report.count_moving, "count_standing": report.count_standing,
                  "in_contact": report.in_contact, "last_obstacle": report.last_obstacle,
                  "last_kind": report.last_kind, "last_stamp": report.last_stamp}
        if report.last_point is not None:
            values.update(zip(("last_x", "last_y", "last_z"), report.last_point))
        status.values = [KeyValue(key=k, value="" if v is None else str(v)) for k, v in values.items()]
        self.collision_pub.publish(status)

    # -- input ----------------------------------------------------------------------------------
    def _on_cmd_vel(self, msg: Twist) -> None:
        try:
            self.sim.set_cmd_vel(msg.linear.x, msg.angular.z, robot=self.index)
        except ValueError as err:
            self.node.get_logger().warn(f"{self.cmd_vel_topic}: {err}", throttle_duration_sec=2.0)
