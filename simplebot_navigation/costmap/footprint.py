"""Robot footprint: parsing, padding, radius polygons and the inscribed/circumscribed radii (docs/reference.md §2.2).

A footprint is an (N, 2) float array of vertices in the robot base frame, in order around the outline.
"""

from __future__ import annotations

import ast
import math

import numpy as np

from simplebot_navigation.geometry import transform_points

#: bounds of a footprint a user may give (docs/reference.md §2.2): more vertices cost every collision check,
#: and a robot's outline lies within a few metres of its base frame
MAX_FOOTPRINT_POINTS = 64
MAX_FOOTPRINT_EXTENT_M = 5.0


def parse_footprint(value, name: str = "footprint") -> np.ndarray:
    """Footprint from a string "[[x, y], ...]" or a list of [x, y] pairs: 3 to 64 distinct points within 5 m of
    the base frame, outlining a simple polygon (no edge crosses another; not all on one line).

    An empty string or "[]" means "no footprint" and returns an empty (0, 2) array, so the
    caller falls back to robot_radius as costmap_2d does.
    """
    if isinstance(value, str):
        text = value.strip()
        if text in ("", "[]"):
            return np.empty((0, 2))
        try:
            value = ast.literal_eval(text)
        except (ValueError, SyntaxError) as exc:
            raise ValueError(f"{name}: cannot parse footprint string {text!r} "
                             f"(expected [[x1, y1], [x2, y2], ...]): {exc}") from None
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{name}: footprint must be a list of [x, y] points, got {value!r}")
    if len(value) == 0:
        return np.empty((0, 2))
    if len(value) < 3:
        raise ValueError(f"{name}: a footprint needs at least three points, got {len(value)}: {value!r}")
    points = []
    for i, point in enumerate(value):
        if not isinstance(point, (list, tuple)) or len(point) != 2:
            raise ValueError(f"{name}: point {i} must be a pair [x, y], got {point!r}")
        for coord in point:
            if isinstance(coord, bool) or not isinstance(coord, (int, float)) or not math.isfinite(coord):
                raise ValueError(f"{name}: point {i} must contain two finite numbers, got {point!r}")
        points.append((float(point[0]), float(point[1])))
    check_outline(np.array(points), name)
    return np.array(points)


def check_outline(points: np.ndarray, name: str = "footprint") -> None:
    """ValueError unless ``points`` outline a simple polygon of MAX_FOOTPRINT_POINTS distinct vertices at most,
    within MAX_FOOTPRINT_EXTENT_M of the origin."""
    if len(points) > MAX_FOOTPRINT_POINTS:
        raise ValueError(f"{name}: a footprint has at most {MAX_FOOTPRINT_POINTS} points, got {len(points)}")
    far = np.flatnonzero(np.abs(points).max(axis=1) > MAX_FOOTPRINT_EXTENT_M)
    if far.size:
        raise ValueError(f"{name}: point {far[0]} {points[far[0]].tolist()} is more than "
                         f"{MAX_FOOTPRINT_EXTENT_M:g} m from the base frame")
    if len(np.unique(points, axis=0)) != len(points):
        raise ValueError(f"{name}: the footprint repeats a point: {points.tolist()}")
    n = len(points)
    for i in range(n):
        for j in range(i + 2, n):
            if (j + 1) % n != i and _segments_cross(points[i], points[(i + 1) % n], points[j], points[(j + 1) % n]):
                raise ValueError(f"{name}: edges {i} and {j} of the footprint cross (not a simple polygon): "
                                 f"{points.tolist()}")
    x, y = points[:, 0], points[:, 1]
    if abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) < 1e-9:
        raise ValueError(f"{name}: the footprint's points lie on one line (no area): {points.tolist()}")


def _segments_cross(a, b, c, d) -> bool:
    """Whether segments ab and cd, which share no end point, touch or cross."""
    def orient(p, q, r):
        return np.sign((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    def on_segment(p, q, r):  # r on pq, given the three are collinear
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[1], q[1])

    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if o1 != o2 and o3 != o4:
        return True
    return any(o == 0 and on_segment(p, q, r) for o, p, q, r in ((o1, a, b, c), (o2, a, b, d),
                                                                   (o3, c, d, a), (o4, c, d, b)))


def footprint_from_radius(radius: float) -> np.ndarray:
    """The 16-gon costmap_2d uses for a round robot (vertices on the circle)."""
    angles = np.arange(16) * 2.0 * math.pi / 16
    return np.stack([np.cos(angles) * radius, np.sin(angles) * radius], axis=1)


def pad_footprint(footprint: np.ndarray, padding: float) -> np.ndarray:
    """Push each vertex outward by `padding` along each axis separately (sign0 rule: 0 stays 0)."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    return fp + np.sign(fp) * padding


def _distance_to_segment(p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Distance from the robot centre to each segment p0[i]-p1[i]."""
    d = p1 - p0
    len_sq = np.einsum("ij,ij->i", d, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", -p0, d) / len_sq
    t = np.where(np.isnan(t), 0.0, np.clip(t, 0.0, 1.0))
    closest = p0 + t[:, None] * d
    return np.hypot(closest[:, 0], closest[:, 1])


def footprint_radii(footprint: np.ndarray) -> tuple[float, float]:
    """(inscribed, circumscribed): nearest edge to the centre and farthest vertex from it.

    Fewer than three points gives (inf, 0), as costmap_2d leaves its initial values.
    """
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    if len(fp) <= 2:
        return math.inf, 0.0
    vertex = np.hypot(fp[:, 0], fp[:, 1])
    edge = _distance_to_segment(fp, np.roll(fp, -1, axis=0))
    return float(min(vertex.min(), edge.min())), float(max(vertex.max(), edge.max()))


def transform_footprint(footprint: np.ndarray, x: float, y: float, yaw: float) -> np.ndarray:
    """Footprint placed at the pose (x, y, yaw) in the global frame."""
    return transform_points((x, y, yaw), np.asarray(footprint, dtype=float).reshape(-1, 2))
