"""The robot's body as the MPPI critics see it, from the local costmap's (padded) footprint: circles that cover it
(against moving obstacles) and points along its outline (against lethal cells, for a body that is not round)."""

from __future__ import annotations

import math

import numpy as np

from simplebot_navigation.costmap.footprint import footprint_radii

#: a footprint whose circumscribed radius exceeds its inscribed one by at most this (m) is a circle (a polygon
#: that approximates one, as footprint_from_radius makes)
ROUND_TOLERANCE_M = 0.02


def is_round(footprint: np.ndarray) -> bool:
    inscribed, circumscribed = footprint_radii(footprint)
    return circumscribed - inscribed <= ROUND_TOLERANCE_M


def _clip(points: np.ndarray, axis: int, low: float, high: float) -> np.ndarray:
    """The polygon (N, 2) cut to low <= p[axis] <= high (Sutherland-Hodgman, one half-plane at a time)."""
    for sign, bound in ((1.0, low), (-1.0, high)):
        kept = []
        for i in range(len(points)):
            p, q = points[i], points[(i + 1) % len(points)]
            dp, dq = sign * (p[axis] - bound), sign * (q[axis] - bound)
            if dp >= 0:
                kept.append(p)
            if dp * dq < 0:
                kept.append(p + (q - p) * dp / (dp - dq))
        points = np.array(kept).reshape(-1, 2)
        if not len(points):
            break
    return points


def body_circles(footprint) -> np.ndarray:
    """(C, 3) circles cx, cy, r in the robot frame that cover the footprint: one for a round body, else one per
    slice of the longer side about as long as the body is wide, each around what of the footprint the slice holds."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    if is_round(fp):
        return np.array([[0.0, 0.0, footprint_radii(fp)[1]]])
    extent = fp.max(axis=0) - fp.min(axis=0)
    axis = int(extent[1] > extent[0])
    n = max(1, math.ceil(extent[axis] / max(extent[1 - axis], 1e-6) - 1e-9))
    edges = np.linspace(fp[:, axis].min(), fp[:, axis].max(), n + 1)
    circles = []
    for low, high in zip(edges[:-1], edges[1:]):
        part = _clip(fp, axis, low, high)
        centre = 0.5 * (part.min(axis=0) + part.max(axis=0))
        circles.append([*centre, float(np.hypot(*(part - centre).T).max())])
    return np.array(circles)


def outline_points(footprint, spacing: float) -> np.ndarray:
    """(P, 2) points along the footprint's edges at most ``spacing`` apart (none for a round body)."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    if is_round(fp) or len(fp) < 3:
        return np.zeros((0, 2))
    points = []
    for p, q in zip(fp, np.roll(fp, -1, axis=0)):
        n = max(1, math.ceil(np.hypot(*(q - p)) / spacing))
        points.append(p + np.linspace(0.0, 1.0, n, endpoint=False)[:, None] * (q - p))
    return np.concatenate(points)
