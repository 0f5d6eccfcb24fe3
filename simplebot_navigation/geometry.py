"""Angles, quaternions and rigid transforms in the plane (SE(2)) and in space (SE(3)).

One home for the math every layer needs, so that the costmaps, the planners, the ROS shells and the
tools agree on conventions: angles in radians, quaternions as (x, y, z, w), planar poses as
(x, y, yaw), spatial transforms as (x, y, z, qx, qy, qz, qw) tuples. No ROS import, so the core
packages can use it. The numba kernels keep their own compiled copies.
"""

from __future__ import annotations

import math

import numpy as np


# -- angles -----------------------------------------------------------------------------------------
def normalize_theta(theta):
    """Angle(s) wrapped into [-pi, pi); works on scalars and arrays."""
    return (np.asarray(theta) + math.pi) % (2 * math.pi) - math.pi


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by yaw about z."""
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def rpy_to_quaternion(rpy) -> tuple[float, float, float, float]:
    """(x, y, z, w) of fixed-axis roll, pitch, yaw (as URDF joint origins give them)."""
    roll, pitch, yaw = rpy
    cr, sr, cp, sp, cy, sy = (f(a / 2) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def axis_angle_to_quaternion(axis, angle: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by angle about a unit axis."""
    s = math.sin(angle / 2)
    return axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2)


def quaternion_to_yaw(x: float, y: float, z: float, w: float) -> float:
    """Heading about z of any rotation (its yaw in roll-pitch-yaw), in (-pi, pi]."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


# -- SE(2): poses (x, y, yaw) ---------------------------------------------------------------------------
def transform_points(pose, points, dtype=float) -> np.ndarray:
    """Rows given in the frame whose pose is `pose`, expressed in that pose's parent frame:
    (N, 2) points, or (N, 3) poses whose yaw is turned too (not wrapped)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    p = np.asarray(points)
    out = np.empty(p.shape, dtype=dtype)
    out[:, 0] = x + c * p[:, 0] - s * p[:, 1]
    out[:, 1] = y + s * p[:, 0] + c * p[:, 1]
    if p.shape[1] == 3:
        out[:, 2] = p[:, 2] + yaw
    return out


def inverse_transform_points(frame, points) -> np.ndarray:
    """Rows given in the parent frame, expressed in the frame whose pose is `frame` (the inverse of
    transform_points): (..., 2) points, or (..., 3) poses whose yaw is turned too (not wrapped). `frame`
    (..., 3) broadcasts against the rows, so N frames can take M points at once ((N, 1, 3) with (1, M, 2))."""
    f, p = np.asarray(frame, dtype=float), np.asarray(points, dtype=float)
    c, s = np.cos(f[..., 2]), np.sin(f[..., 2])
    dx, dy = p[..., 0] - f[..., 0], p[..., 1] - f[..., 1]
    rows = [c * dx + s * dy, -s * dx + c * dy]
    if p.shape[-1] == 3:
        rows.append(p[..., 2] - f[..., 2])
    return np.stack(rows, axis=-1)


def pose_in_frame(frame, pose) -> tuple[float, float, float]:
    """A pose given in the parent frame, expressed in the frame whose pose is `frame` (yaw wrapped)."""
    x, y = inverse_transform_points(frame, pose[:2]).tolist()
    return x, y, math.remainder(pose[2] - frame[2], 2 * math.pi)


def compose2(a, b) -> tuple[float, float, float]:
    """a * b of two (x, y, yaw): b expressed in a's parent frame (yaw wrapped)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], math.remainder(a[2] + b[2], 2 * math.pi)


def inverse2(a) -> tuple[float, float, float]:
    c, s = math.cos(a[2]), math.sin(a[2])
    return -c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2]


# -- SE(3): transforms (x, y, z, qx, qy, qz, qw) ------------------------------------------------------
def quaternion_multiply(a, b) -> tuple[float, float, float, float]:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def rotate_vector(q, v) -> tuple[float, float, float]:
    x, y, z, _ = quaternion_multiply(quaternion_multiply(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def quaternion_to_rotation_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """3x3 rotation matrix of a unit quaternion."""
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def compose(a, b) -> tuple:
    """a * b: b expressed in a's parent frame."""
    t = rotate_vector(a[3:], b[:3])
    q = quaternion_multiply(a[3:], b[3:])
    return (a[0] + t[0], a[1] + t[1], a[2] + t[2], *q)


def inverse(a) -> tuple:
    qi = (-a[3], -a[4], -a[5], a[6])
    t = rotate_vector(qi, a[:3])
    return (-t[0], -t[1], -t[2], *qi)


def slerp(q0, q1, ratio: float) -> tuple:
    """Shortest-arc spherical interpolation between unit quaternions (linear when nearly equal)."""
    dot = sum(x * y for x, y in zip(q0, q1))
    if dot < 0.0:
        q1, dot = tuple(-x for x in q1), -dot
    if dot > 0.9995:
        q = tuple(x + ratio * (y - x) for x, y in zip(q0, q1))
    else:
        theta = math.acos(min(1.0, dot))
        s0 = math.sin((1 - ratio) * theta) / math.sin(theta)
        s1 = math.sin(ratio * theta) / math.sin(theta)
        q = tuple(s0 * x + s1 * y for x, y in zip(q0, q1))
    norm = math.sqrt(sum(x * x for x in q))
    return tuple(x / norm for x in q)


def interpolate(a, b, ratio: float) -> tuple:
    """The transform `ratio` of the way from a to b: linear translation, slerp rotation."""
    return (*(a[i] + ratio * (b[i] - a[i]) for i in range(3)), *slerp(a[3:], b[3:], ratio))
