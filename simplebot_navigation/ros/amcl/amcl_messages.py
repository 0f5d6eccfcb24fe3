"""amcl's messages as the filter's plain values and back: scans, initial poses and the estimate."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import PoseWithCovarianceStamped
from sensor_msgs.msg import LaserScan


from simplebot_navigation.geometry import quaternion_to_yaw
from simplebot_navigation.localization.amcl_params import MAX_BEAMS
from simplebot_navigation.localization.clusters import PoseEstimate, covariance_from_ros
from simplebot_navigation.localization.laser_models import RangeScan
from simplebot_navigation.ros.conversions import xyyaw_to_pose

#: the latest stamp a message can carry (builtin_interfaces/Time's sec is an int32)
LATEST_STAMP_NS = (2 ** 31 - 1) * 10 ** 9 + 999_999_999


def range_scan(msg: LaserScan, sensor_pose: tuple[float, float, float]) -> RangeScan:
    """The filter's scan of a LaserScan whose frame sits at ``sensor_pose`` in the base frame; ValueError naming
    the field that cannot be used."""
    if not 1 <= len(msg.ranges) <= MAX_BEAMS:
        raise ValueError(f"ranges: 1 to {MAX_BEAMS} beams, got {len(msg.ranges)}")
    if not (math.isfinite(msg.angle_increment) and msg.angle_increment != 0.0):
        raise ValueError(f"angle_increment: must be finite and non-zero, got {msg.angle_increment!r}")
    scan = RangeScan(np.asarray(msg.ranges, dtype=np.float64), float(msg.angle_min), float(msg.angle_increment),
                     float(msg.range_min), float(msg.range_max), sensor_pose)
    scan.check()
    return scan


def post_dated(stamp_ns: int, seconds: float) -> TimeMsg:
    """The stamp ``seconds`` after ``stamp_ns``, saturating at the latest stamp a message can carry (a scan near it
    with the largest transform_tolerance would otherwise not fit in the message)."""
    ns = min(stamp_ns + round(seconds * 1e9), LATEST_STAMP_NS)
    return TimeMsg(sec=ns // 10 ** 9, nanosec=ns % 10 ** 9)


def initial_pose(msg: PoseWithCovarianceStamped) -> tuple[float, float, float, np.ndarray]:
    """(x, y, yaw, 3x3 covariance) of /initialpose in its own frame; ValueError naming a field that is not finite."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    for name, value in (("pose.position.x", p.x), ("pose.position.y", p.y), ("pose.orientation.z", q.z),
                        ("pose.orientation.w", q.w)):
        if not math.isfinite(value):
            raise ValueError(f"{name} is {value}")
    if math.hypot(q.x, q.y, q.z, q.w) < 1e-6:
        raise ValueError("pose.orientation is a zero quaternion")
    if len(msg.pose.covariance) != 36 or not all(math.isfinite(c) for c in msg.pose.covariance):
        raise ValueError("pose.covariance: must be 36 finite numbers")
    return p.x, p.y, quaternion_to_yaw(q.x, q.y, q.z, q.w), covariance_from_ros(msg.pose.covariance)


def estimate_msg(estimate: PoseEstimate, frame_id: str, stamp) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id, msg.header.stamp = frame_id, stamp
    msg.pose.pose = xyyaw_to_pose(estimate.x, estimate.y, estimate.yaw)
    msg.pose.covariance = estimate.ros_covariance()
    return msg
