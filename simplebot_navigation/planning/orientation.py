"""global_planner's OrientationFilter: the yaw of every plan pose (docs/reference.md §3.4).

The last pose always keeps the goal's yaw. One deliberate fix: ROS 1 interpolates from index
``start_index`` with ``start_yaw + increment * i`` (absolute i), which in
ForwardThenInterpolate makes the blend overshoot the goal heading; here the blend runs from the
first interpolated pose's yaw to the goal's yaw, as the mode's description says.
"""

from __future__ import annotations

import numpy as np

from simplebot_navigation.planning.config import OrientationMode

#: ForwardThenInterpolate: heading change (rad) that ends the final straight section.
STRAIGHT_TOLERANCE = 0.35

_OFFSETS = {
    OrientationMode.FORWARD: 0.0,
    OrientationMode.BACKWARD: np.pi,
    OrientationMode.LEFTWARD: -np.pi / 2,
    OrientationMode.RIGHTWARD: np.pi / 2,
}


def normalize_angle(a):
    """Wrap to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _shortest(a: float, b: float) -> float:
    return float(normalize_angle(b - a))


def _position_derivative_yaw(xy: np.ndarray, window: int) -> np.ndarray:
    """Heading from point i - window to point i + window (indices clipped to the path)."""
    n = len(xy)
    i = np.arange(n)
    i0 = np.maximum(0, i - window)
    i1 = np.minimum(n - 1, i + window)
    d = xy[i1] - xy[i0]
    return np.arctan2(d[:, 1], d[:, 0])


def _interpolate(yaw: np.ndarray, first: int, last: int) -> None:
    diff = _shortest(yaw[first], yaw[last])
    steps = np.arange(last - first + 1)
    yaw[first:last + 1] = normalize_angle(yaw[first] + diff * steps / max(last - first, 1))


def orient_path(xy: np.ndarray, start_yaw: float, goal_yaw: float, mode: OrientationMode,
                window: int) -> np.ndarray:
    """Yaw for each point of ``xy`` (N, 2; the last point is the goal)."""
    n = len(xy)
    yaw = np.zeros(n)
    if n == 0:
        return yaw
    yaw[-1] = goal_yaw
    if n == 1 or mode == OrientationMode.NONE:
        return yaw
    if mode in _OFFSETS:
        yaw[:-1] = normalize_angle(_position_derivative_yaw(xy, window)[:-1] + _OFFSETS[mode])
    elif mode == OrientationMode.INTERPOLATE:
        yaw[0] = start_yaw
        _interpolate(yaw, 0, n - 1)
    elif mode == OrientationMode.FORWARD_THEN_INTERPOLATE:
        yaw[:-1] = _position_derivative_yaw(xy, window)[:-1]
        i = max(n - 3, 0)
        last = yaw[i]
        while i > 0 and abs(_shortest(yaw[i - 1], last)) <= STRAIGHT_TOLERANCE:
            i -= 1
        yaw[0] = start_yaw
        _interpolate(yaw, i, n - 1)
    return yaw
