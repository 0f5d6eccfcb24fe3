"""Message <-> numpy conversions shared by the nodes (the only place message layouts are spelled out)."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg, Time as TimeMsg
from geometry_msgs.msg import Point32, PolygonStamped, Pose, PoseArray, PoseStamped, Quaternion, TransformStamped
from nav_msgs.msg import OccupancyGrid, Path

from simplebot_navigation.costmap.cost_values import OCCUPANCY_GRID_TABLE
from simplebot_navigation.geometry import quaternion_to_yaw, yaw_to_quaternion
from simplebot_navigation.maps import MAX_CELLS
from simplebot_navigation.maps.map_io import OccupancyMap


def duration_msg(seconds: float) -> DurationMsg:
    """A Duration of ``seconds``, clamped to what the message can hold (int32 seconds); NaN is 0."""
    seconds = min(max(seconds, 0.0), 2.0 ** 31 - 1) if not math.isnan(seconds) else 0.0
    whole = math.floor(seconds)
    return DurationMsg(sec=int(whole), nanosec=min(int(round((seconds - whole) * 1e9)), 999_999_999))


def duration_s(msg: DurationMsg) -> float:
    return msg.sec + msg.nanosec * 1e-9


def quaternion_msg(yaw: float) -> Quaternion:
    x, y, z, w = yaw_to_quaternion(yaw)
    return Quaternion(x=x, y=y, z=z, w=w)


def yaw_of(q) -> float:
    """Heading of a geometry_msgs/Quaternion."""
    return quaternion_to_yaw(q.x, q.y, q.z, q.w)


def pose_to_xyyaw(pose: Pose) -> tuple[float, float, float]:
    return pose.position.x, pose.position.y, yaw_of(pose.orientation)


def xyyaw_to_pose(x: float, y: float, yaw: float) -> Pose:
    pose = Pose()
    pose.position.x, pose.position.y = float(x), float(y)
    pose.orientation = quaternion_msg(float(yaw))
    return pose


def transform_to_xyyaw(tf: TransformStamped) -> tuple[float, float, float]:
    t = tf.transform.translation
    return t.x, t.y, yaw_of(tf.transform.rotation)


def path_msg(poses: np.ndarray, frame_id: str, stamp: TimeMsg) -> Path:
    """nav_msgs/Path from an (N, 3) array of x, y, yaw."""
    msg = Path()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    for x, y, yaw in np.asarray(poses, dtype=float).reshape(-1, 3):
        ps = PoseStamped()
        ps.header = msg.header
        ps.pose = xyyaw_to_pose(x, y, yaw)
        msg.poses.append(ps)
    return msg


def path_to_array(msg: Path) -> np.ndarray:
    return np.array([pose_to_xyyaw(p.pose) for p in msg.poses], dtype=float).reshape(-1, 3)


def pose_array_msg(poses: np.ndarray, frame_id: str, stamp: TimeMsg) -> PoseArray:
    msg = PoseArray()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.poses = [xyyaw_to_pose(x, y, yaw) for x, y, yaw in np.asarray(poses, dtype=float).reshape(-1, 3)]
    return msg


def polygon_msg(points: np.ndarray, frame_id: str, stamp: TimeMsg) -> PolygonStamped:
    msg = PolygonStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.polygon.points = [Point32(x=float(x), y=float(y), z=0.0) for x, y in np.asarray(points).reshape(-1, 2)]
    return msg


def occupancy_grid_msg(costs: np.ndarray, resolution: float, origin_x: float, origin_y: float,
                       frame_id: str, stamp: TimeMsg) -> OccupancyGrid:
    """A costmap grid (uint8 costs, [row=y, col=x]) as nav_msgs/OccupancyGrid with costmap_2d's table."""
    msg = OccupancyGrid()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.info.map_load_time = stamp
    msg.info.resolution = float(resolution)
    msg.info.height, msg.info.width = (int(v) for v in costs.shape)
    msg.info.origin.position.x = float(origin_x)
    msg.info.origin.position.y = float(origin_y)
    msg.info.origin.orientation.w = 1.0
    msg.data = OCCUPANCY_GRID_TABLE[costs].ravel().tobytes()
    return msg


def occupancy_map_msg(occupancy_map: OccupancyMap, stamp: TimeMsg) -> OccupancyGrid:
    """A map_server map as nav_msgs/OccupancyGrid (its cells as they are, row 0 at the origin)."""
    msg = OccupancyGrid()
    msg.header.frame_id = occupancy_map.frame_id
    msg.header.stamp = stamp
    msg.info.map_load_time = stamp
    msg.info.resolution = float(occupancy_map.resolution)
    msg.info.width, msg.info.height = occupancy_map.width, occupancy_map.height
    x, y, yaw = occupancy_map.origin
    msg.info.origin.position.x, msg.info.origin.position.y = float(x), float(y)
    msg.info.origin.orientation = quaternion_msg(yaw)
    msg.data = occupancy_map.data.tobytes()
    return msg


def checked_occupancy_map(msg: OccupancyGrid, user: str) -> OccupancyMap:
    """The map of an OccupancyGrid from any node, or ValueError naming what is wrong: more than MAX_CELLS cells
    (`user`'s bound, docs/reference.md §7.1), no cells, a resolution that is not a positive number, or data that do
    not fill width x height."""
    info = msg.info
    if info.width * info.height > MAX_CELLS:
        raise ValueError(f"{info.width} x {info.height} = {info.width * info.height} cells, more than {user}'s bound "
                         f"of {MAX_CELLS} (docs/reference.md §7.1)")
    if not (math.isfinite(info.resolution) and info.resolution > 0) or info.width * info.height == 0:
        raise ValueError(f"{info.width} x {info.height} cells of {info.resolution} m (cells and a positive size "
                         "needed)")
    return occupancy_map_from_msg(msg)


def occupancy_map_from_msg(msg: OccupancyGrid) -> OccupancyMap:
    """The map a nav_msgs/OccupancyGrid carries; ValueError if its data does not fill width x height."""
    info = msg.info
    if len(msg.data) != info.width * info.height:
        raise ValueError(f"{len(msg.data)} cells for {info.width} x {info.height}")
    data = np.array(msg.data, dtype=np.int8).reshape(info.height, info.width)
    # resolution is a float32 field: its shortest decimal is the value the publisher meant (0.05, not 0.0500000007)
    return OccupancyMap(data, float(str(np.float32(info.resolution))),
                        (info.origin.position.x, info.origin.position.y, yaw_of(info.origin.orientation)),
                        msg.header.frame_id)


def stamp_seconds(t) -> float:
    """An rclpy Time in seconds."""
    return t.nanoseconds * 1e-9
