"""TEB robot footprint models (docs/reference.md §4.3): the shapes the optimiser keeps away from obstacles.

Every model is a union of primitives in the robot frame -- circles (a point is a circle of
radius 0) and segments (a line is one segment, a polygon its closed outline) -- so one
vectorised routine gives distances and their gradients for all five types. Obstacles are
mapped into each pose's robot frame, q = R(-theta) (o - p); the pose gradient follows from
dd/dp = -R(theta) dd/dq and dd/dtheta = dd/dq . (q_y, -q_x).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from simplebot_navigation.costmap.footprint import parse_footprint
from simplebot_navigation.geometry import inverse_transform_points
from simplebot_navigation.parameters import Param, ParameterError, fields_of, load, param

MODEL_TYPES = ("point", "circular", "two_circles", "line", "polygon")


class FootprintModel:
    def __init__(self, kind: str, circles=(), segments=(), closed_polygon: bool = False,
                 vertices=None, warnings=None):
        self.kind = kind
        self.circles = np.asarray(circles, dtype=float).reshape(-1, 3)       # cx, cy, r
        self.segments = np.asarray(segments, dtype=float).reshape(-1, 4)     # ax, ay, bx, by
        self.closed_polygon = closed_polygon
        self.vertices = None if vertices is None else np.asarray(vertices, dtype=float)
        self.warnings = list(warnings or [])

    # -- construction -----------------------------------------------------------------
    @classmethod
    def point(cls, warnings=None) -> "FootprintModel":
        return cls("point", circles=[(0.0, 0.0, 0.0)], warnings=warnings)

    @classmethod
    def circular(cls, radius: float) -> "FootprintModel":
        return cls("circular", circles=[(0.0, 0.0, radius)])

    @classmethod
    def two_circles(cls, front_offset: float, front_radius: float,
                    rear_offset: float, rear_radius: float) -> "FootprintModel":
        return cls("two_circles", circles=[(front_offset, 0.0, front_radius),
                                           (-rear_offset, 0.0, rear_radius)])

    @classmethod
    def line(cls, line_start, line_end) -> "FootprintModel":
        return cls("line", segments=[(*line_start, *line_end)])

    @classmethod
    def polygon(cls, vertices) -> "FootprintModel":
        v = np.asarray(vertices, dtype=float)
        segs = np.hstack([v, np.roll(v, -1, axis=0)])
        return cls("polygon", segments=segs, closed_polygon=True, vertices=v)

    @classmethod
    def from_params(cls, params: dict | None) -> "FootprintModel":
        """The ``footprint_model`` sub-namespace. Missing or unknown type, or missing
        parameters of a known type, fall back to ``point`` with a warning, as TEB does;
        present but malformed values raise ParameterError naming the parameter."""
        given, warnings = load(fields_of(FootprintModelParams), params or {}, "footprint_model")
        model = cls._from_checked(given)
        model.warnings = warnings + model.warnings
        return model

    @classmethod
    def _from_checked(cls, given: dict) -> "FootprintModel":
        kind = given.get("type")
        if kind is None:
            return cls.point(["footprint_model/type not specified: using the point model "
                              "(min_obstacle_dist must include the robot radius)"])
        if kind not in MODEL_TYPES:
            return cls.point([f"footprint_model/type {kind!r} is not one of {', '.join(MODEL_TYPES)}: "
                              "using the point model"])
        needs = {"point": (), "circular": ("radius",), "line": ("line_start", "line_end"), "polygon": ("vertices",),
                 "two_circles": ("front_offset", "front_radius", "rear_offset", "rear_radius")}[kind]
        missing = [name for name in needs if name not in given]
        if missing:
            return cls.point([f"footprint_model/{', '.join(missing)} missing for type '{kind}': "
                              "using the point model"])
        if kind == "point":
            return cls.point()
        if kind == "circular":
            return cls.circular(given["radius"])
        if kind == "two_circles":
            return cls.two_circles(*(given[name] for name in needs))
        if kind == "line":
            return cls.line(_xy(given, "line_start"), _xy(given, "line_end"))
        # a list, or the "[[x, y], ...]" string a nested list becomes as a ROS 2 parameter
        vertices = parse_footprint(given["vertices"], "footprint_model/vertices")
        if len(vertices) < 3:
            raise ParameterError(f"footprint_model/vertices: expected a list of at least 3 [x, y] points, "
                                 f"got {given['vertices']!r}")
        return cls.polygon([tuple(v) for v in vertices])

    # -- geometry -----------------------------------------------------------------------
    @cached_property
    def kernel_model(self) -> tuple:
        """The model as teb/footprint_kernels.py takes it: (circles, segments, vertices, closed)."""
        vertices = np.zeros((0, 2)) if self.vertices is None else self.vertices
        return (np.ascontiguousarray(self.circles), np.ascontiguousarray(self.segments),
                np.ascontiguousarray(vertices, dtype=float), bool(self.closed_polygon))

    @cached_property
    def bounding_radius(self) -> float:
        """Largest distance from the robot centre to any point of the model."""
        r = 0.0
        if len(self.circles):
            r = max(r, float(np.max(np.hypot(self.circles[:, 0], self.circles[:, 1]) + self.circles[:, 2])))
        if len(self.segments):
            r = max(r, float(np.max(np.hypot(self.segments[:, [0, 2]], self.segments[:, [1, 3]]))))
        return r

    @cached_property
    def inscribed_radius(self) -> float:
        if self.kind == "circular":
            return float(self.circles[0, 2])
        if self.kind == "two_circles":
            (fo, _, fr), (ro, _, rr) = self.circles[0], self.circles[1]
            ro = -ro
            return min(min(ro + rr, fo + fr), min(rr, fr))
        if self.kind == "polygon":
            d, _ = self._robot_frame_distance(np.zeros((1, 2)))
            return float(-d[0]) if d[0] < 0 else 0.0
        return 0.0

    def _robot_frame_distance(self, q: np.ndarray):
        """Distance (K,) and its gradient wrt q (K,2) for robot-frame points q (K,2)."""
        best_d = np.full(len(q), np.inf)
        best_g = np.zeros((len(q), 2))
        if len(self.circles):
            diff = q[:, None, :] - self.circles[None, :, :2]                 # K,C,2
            norm = np.sqrt(np.einsum("kcj,kcj->kc", diff, diff))
            d = norm - self.circles[None, :, 2]
            j = np.argmin(d, axis=1)
            k = np.arange(len(q))
            best_d = d[k, j]
            n = norm[k, j]
            safe = np.where(n > 1e-12, n, 1.0)[:, None]
            best_g = np.where(n[:, None] > 1e-12, diff[k, j] / safe, 0.0)
        if len(self.segments):
            a = self.segments[None, :, :2]
            ab = self.segments[None, :, 2:] - a
            len2 = np.einsum("ksj,ksj->ks", ab, ab)
            aq = q[:, None, :] - a
            t = np.clip(np.einsum("ksj,ksj->ks", aq, ab) / np.where(len2 > 0, len2, 1.0), 0.0, 1.0)
            diff = aq - t[..., None] * ab
            norm = np.sqrt(np.einsum("ksj,ksj->ks", diff, diff))
            j = np.argmin(norm, axis=1)
            k = np.arange(len(q))
            seg_d = norm[k, j]
            safe = np.where(seg_d > 1e-12, seg_d, 1.0)[:, None]
            seg_g = np.where(seg_d[:, None] > 1e-12, diff[k, j] / safe, 0.0)
            if self.closed_polygon:
                sign = np.where(_inside_polygon(q, self.vertices), -1.0, 1.0)
                seg_d = seg_d * sign
                seg_g = seg_g * sign[:, None]
            take = seg_d < best_d
            best_d = np.where(take, seg_d, best_d)
            best_g = np.where(take[:, None], seg_g, best_g)
        return best_d, best_g

    def distances(self, poses: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Distance matrix (N, M) from N poses (N,3) to M point obstacles (M,2)."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if not len(self.segments):
            return self._circle_pairs(poses[:, None, :], points[None, :, :], False)[0]
        q = inverse_transform_points(poses[:, None, :], points[None, :, :])
        d, _ = self._robot_frame_distance(q.reshape(-1, 2))
        return d.reshape(len(poses), len(points))

    def pair_distances(self, poses: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Pairwise distances (K,) between poses[k] (K,3) and points[k] (K,2)."""
        if not len(self.segments):
            return self._circle_pairs(poses, points, False)[0]
        return self._robot_frame_distance(inverse_transform_points(poses, points))[0]

    def _circle_pairs(self, poses, points, with_gradient: bool):
        """World-frame shortcut for circle-only models (point, circular, two_circles): the
        optimiser's hot loop, so no (K, C, 2) temporaries. Broadcasts poses against points."""
        c, s = np.cos(poses[..., 2]), np.sin(poses[..., 2])
        best_d = best_g = None
        for cx, cy, r in self.circles:
            ex = points[..., 0] - (poses[..., 0] + c * cx - s * cy)
            ey = points[..., 1] - (poses[..., 1] + s * cx + c * cy)
            norm = np.hypot(ex, ey)
            d = norm - r
            grad = None
            if with_gradient:
                inv = np.divide(1.0, norm, out=np.zeros_like(norm), where=norm > 1e-12)
                grad = np.stack([-ex * inv, -ey * inv,
                                 (ex * (s * cx + c * cy) - ey * (c * cx - s * cy)) * inv], axis=1)
            if best_d is None:
                best_d, best_g = d, grad
            else:
                take = d < best_d
                best_d = np.where(take, d, best_d)
                if with_gradient:
                    best_g = np.where(take[:, None], grad, best_g)
        return best_d, best_g

    def distance_and_gradient(self, poses: np.ndarray, points: np.ndarray):
        """Pairwise distances (K,) between poses[k] and points[k], and d(dist)/d(x, y, theta) (K,3)."""
        if not len(self.segments):
            return self._circle_pairs(poses, points, True)
        q = inverse_transform_points(poses, points)
        d, gq = self._robot_frame_distance(q)
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        grad = np.empty((len(d), 3))
        grad[:, 0] = -(c * gq[:, 0] - s * gq[:, 1])
        grad[:, 1] = -(s * gq[:, 0] + c * gq[:, 1])
        grad[:, 2] = gq[:, 0] * q[:, 1] - gq[:, 1] * q[:, 0]
        return d, grad

    def outline(self, poses: np.ndarray, circle_points: int = 16) -> list[list[np.ndarray]]:
        """World-frame outlines of the model at each pose (for markers): per pose one polyline per
        circle, polygon or line, so that a marker never joins two circles with a chord."""
        parts = []
        ang = np.linspace(0.0, 2 * math.pi, circle_points + 1)
        for cx, cy, r in self.circles:
            parts.append(np.stack([cx + r * np.cos(ang), cy + r * np.sin(ang)], axis=1) if r > 0
                         else np.array([[cx, cy]]))
        if self.closed_polygon:
            parts.append(np.vstack([self.vertices, self.vertices[:1]]))
        elif len(self.segments):
            parts.append(self.segments[0].reshape(2, 2))
        out = []
        for x, y, th in np.asarray(poses, dtype=float).reshape(-1, 3):
            c, s = math.cos(th), math.sin(th)
            out.append([np.stack([x + c * part[:, 0] - s * part[:, 1], y + s * part[:, 0] + c * part[:, 1]], axis=1)
                        for part in parts])
        return out


def _inside_polygon(q: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Even-odd rule, vectorised over query points."""
    x, y = q[:, 0:1], q[:, 1:2]
    xi, yi = vertices[None, :, 0], vertices[None, :, 1]
    xj, yj = np.roll(vertices[:, 0], 1)[None, :], np.roll(vertices[:, 1], 1)[None, :]
    crosses = ((yi > y) != (yj > y)) & (x < (xj - xi) * (y - yi) / np.where(yj != yi, yj - yi, 1.0) + xi)
    return (np.count_nonzero(crosses, axis=1) % 2) == 1


@dataclass
class FootprintModelParams:
    """``TebLocalPlannerROS/footprint_model``: the shape the optimiser keeps away from obstacles."""
    type: str = param("point", "", f"model type: {', '.join(MODEL_TYPES)}", restart=True)
    radius: float = param(0.0, "m", "radius (circular)", ge=0)
    front_offset: float = param(0.0, "m", "front circle centre ahead of the base (two_circles)")
    front_radius: float = param(0.0, "m", "front circle radius (two_circles)", ge=0)
    rear_offset: float = param(0.0, "m", "rear circle centre behind the base (two_circles)")
    rear_radius: float = param(0.0, "m", "rear circle radius (two_circles)", ge=0)
    line_start: list = param([], "m", "[x, y] where the segment starts (line)")
    line_end: list = param([], "m", "[x, y] where the segment ends (line)")
    vertices: list = param([], "m", "[[x, y], ...] in the base frame, or its string form (polygon)",
                           kind=(list, str))


#: a coordinate of a line model
_COORDINATE = Param(float, 0.0, "m", "footprint model coordinate")


def _xy(given: dict, name: str) -> tuple[float, float]:
    v = given[name]
    if len(v) != 2:
        raise ParameterError(f"footprint_model/{name}: expected [x, y], got {v!r}")
    return (_COORDINATE.check(v[0], f"footprint_model/{name}[0]"),
            _COORDINATE.check(v[1], f"footprint_model/{name}[1]"))
