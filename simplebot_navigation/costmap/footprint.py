"""Robot footprint: parsing, padding, radius polygons, the inscribed/circumscribed radii (docs/reference.md §2.2)
and the footprint cost of poses on a costmap (base_local_planner's CostmapModel::footprintCost).

A footprint is an (N, 2) float array of vertices in the robot base frame, in order around the outline.
"""

from __future__ import annotations

import ast
import math

import numpy as np

from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
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
    """(inscribed, circumscribed) as costmap_2d's calculateMinAndMaxDistances: the nearest edge to the centre
    and the farthest vertex from it (an edge is never nearer than its nearest point nor farther than its
    farthest vertex). Fewer than three points give (inf, 0), the values costmap_2d leaves.
    """
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    if len(fp) < 3:
        return math.inf, 0.0
    edge = _distance_to_segment(fp, np.roll(fp, -1, axis=0))
    return float(edge.min()), float(np.hypot(fp[:, 0], fp[:, 1]).max())


def transform_footprint(footprint: np.ndarray, x: float, y: float, yaw: float) -> np.ndarray:
    """Footprint placed at the pose (x, y, yaw) in the global frame."""
    return transform_points((x, y, yaw), np.asarray(footprint, dtype=float).reshape(-1, 2))


def line_cells(x0, y0, x1, y1):
    """Vectorised costmap LineIterator (Bresenham) for many lines at once.

    Returns (line index, mx, my) of every visited cell, endpoints included, in visiting order.
    The minor coordinate after k steps advanced floor((den // 2 + k * numadd) / den) times.
    """
    dx, dy = np.abs(x1 - x0), np.abs(y1 - y0)
    sx, sy = np.where(x1 >= x0, 1, -1), np.where(y1 >= y0, 1, -1)
    x_major = dx >= dy
    den = np.where(x_major, dx, dy)
    numadd = np.where(x_major, dy, dx)
    counts = den + 1
    line = np.repeat(np.arange(len(x0)), counts)
    k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    den_l = np.maximum(den[line], 1)
    minor = (den[line] // 2 + k * numadd[line]) // den_l
    xm = x_major[line]
    mx = x0[line] + sx[line] * np.where(xm, k, minor)
    my = y0[line] + sy[line] * np.where(xm, minor, k)
    return line, mx, my


def footprint_costs(costmap, footprint: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """footprintCost sign per pose: -1 lethal, -2 unknown, -3 off map, 0 otherwise.

    The outline is rasterised edge by edge with the LineIterator, and the first lethal or unknown cell
    met in that order decides (lethal -> -1, unknown -> -2); a vertex or the centre off the map gives -3.
    Fewer than three points check the centre cell only, where an inscribed cost counts as lethal.
    """
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    out = np.zeros(len(poses))
    grid = costmap.costmap
    cx, cy, centre_ok = costmap.world_to_map_array(poses[:, 0], poses[:, 1])
    out[~centre_ok] = -3.0
    if len(fp) < 3:
        cost = np.where(centre_ok, grid[np.where(centre_ok, cy, 0), np.where(centre_ok, cx, 0)], 0)
        out[centre_ok & (cost == NO_INFORMATION)] = -2.0
        out[centre_ok & ((cost == LETHAL_OBSTACLE) | (cost == INSCRIBED_INFLATED_OBSTACLE))] = -1.0
        return out
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    wx = poses[:, 0:1] + c * fp[None, :, 0] - s * fp[None, :, 1]
    wy = poses[:, 1:2] + s * fp[None, :, 0] + c * fp[None, :, 1]
    vx, vy, v_ok = costmap.world_to_map_array(wx, wy)
    on_map = centre_ok & v_ok.all(axis=1)
    out[centre_ok & ~on_map] = -3.0
    idx = np.nonzero(on_map)[0]
    if not len(idx):
        return out
    nv = len(fp)
    x0, y0 = vx[idx].ravel(), vy[idx].ravel()
    x1, y1 = np.roll(vx[idx], -1, axis=1).ravel(), np.roll(vy[idx], -1, axis=1).ravel()
    # costmap_2d closes the polygon with an explicit last edge; the order of edges matters only
    # for which of lethal/unknown is met first, and line i precedes line i+1 as in the loop.
    line, mx, my = line_cells(x0, y0, x1, y1)
    cost = grid[my, mx]
    hit = (cost == LETHAL_OBSTACLE) | (cost == NO_INFORMATION)
    if not hit.any():
        return out
    pose_of_cell = line[hit] // nv
    first = np.unique(pose_of_cell, return_index=True)
    first_cost = cost[hit][first[1]]
    out[idx[first[0]]] = np.where(first_cost == LETHAL_OBSTACLE, -1.0, -2.0)
    return out
