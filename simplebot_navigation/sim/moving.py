"""Moving obstacles: cylinders and boxes that follow keyframes (t, x, y) through simulated time.

A world file lists them under ``moving:`` (world.py parses the file, MovingObstacle checks the values).
Positions between keyframes are linear or Catmull-Rom ("spline"); both are evaluated as cubic Hermite
segments (linear ones with the secant as both tangents), so one vectorised evaluation, MovingTracks,
serves any mix of obstacles: the simulator evaluates all of them at every physics step.

The lidars meet them in closed form (MovingTracks.ray_fractions: ray against circle or axis-aligned
rectangle, in numpy) rather than in Bullet's ray batch: Bullet casts rays against convex primitives by
GJK, and 24 cylinders in view made a lab scan ten times dearer (3 ms -> 26 ms a batch).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple, Sequence

import numpy as np

DEFAULT_HEIGHT = 1.0
SHAPES = ("cylinder", "box")
INTERPOLATIONS = ("linear", "spline")


class MovingObstacleError(ValueError):
    """A bad value of a MovingObstacle; ``key`` is the world-file key it came from."""

    def __init__(self, key: str, problem: str):
        super().__init__(f"{key}: {problem}")
        self.key, self.problem = key, problem


@dataclass(frozen=True)
class MovingObstacle:
    """A cylinder or an axis-aligned box whose centre follows ``keyframes`` ((t, x, y), t increasing).

    Animation time is ``tau = t - phase``. Before the first keyframe the obstacle rests there, after
    the last it rests there too, or with ``loop`` jumps back to the first and repeats.
    """

    shape: str
    keyframes: tuple[tuple[float, float, float], ...]
    radius: float = 0.0
    size: tuple[float, float] = (0.0, 0.0)
    height: float = DEFAULT_HEIGHT
    interpolation: str = "linear"
    loop: bool = False
    phase: float = 0.0
    name: str | None = None

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise MovingObstacleError("shape", f"unknown shape {self.shape!r} (expected {' or '.join(SHAPES)})")
        if self.interpolation not in INTERPOLATIONS:
            raise MovingObstacleError("interpolation", f"unknown interpolation {self.interpolation!r} "
                                                       f"(expected {' or '.join(INTERPOLATIONS)})")
        if len(self.keyframes) < 2:
            raise MovingObstacleError("keyframes", f"needs at least 2 keyframes [t, x, y], got {len(self.keyframes)}")
        for i, frame in enumerate(self.keyframes):
            if len(frame) != 3 or not all(math.isfinite(value) for value in frame):
                raise MovingObstacleError(f"keyframes[{i}]", f"expected a finite [t, x, y], got {list(frame)}")
            if i and frame[0] <= self.keyframes[i - 1][0]:
                raise MovingObstacleError(f"keyframes[{i}]", f"time {frame[0]} is not after the previous keyframe's "
                                                             f"{self.keyframes[i - 1][0]}")
        extent = ("radius", (self.radius,)) if self.shape == "cylinder" else ("size", self.size)
        for key, values in (extent, ("height", (self.height,))):
            if not all(math.isfinite(value) and value > 0 for value in values):
                raise MovingObstacleError(key, f"{key} must be positive and finite, got "
                                               f"{values[0] if len(values) == 1 else list(values)}")
        if not math.isfinite(self.phase):
            raise MovingObstacleError("phase", f"expected a finite number, got {self.phase}")

    def state(self, t: float) -> tuple[float, float, float, float]:
        """(x, y, vx, vy) at sim time t."""
        return tuple(float(v) for v in self._track.states(t)[0])

    def bounding_radius(self) -> float:
        """Radius of the smallest circle around its centre that holds the whole shape."""
        return self.radius if self.shape == "cylinder" else math.hypot(*self.size) / 2

    def extent(self) -> float | tuple[float, float]:
        """The radius of a cylinder, the size of a box."""
        return self.radius if self.shape == "cylinder" else self.size

    @cached_property
    def _track(self) -> MovingTracks:
        return MovingTracks((self,))


class MovingObstacleState(NamedTuple):
    """Ground truth of one moving obstacle at one time; ``extent`` is a radius or a box's (sx, sy)."""

    label: str
    shape: str
    x: float
    y: float
    vx: float
    vy: float
    extent: float | tuple[float, float]


def obstacle_label(index: int, obstacle: MovingObstacle) -> str:
    """The label collision reports and ground truth use: "moving[3]" or "moving[3] (name)"."""
    return f"moving[{index}] ({obstacle.name})" if obstacle.name else f"moving[{index}]"


def _tangents(times: np.ndarray, points: np.ndarray, obstacle: MovingObstacle) -> tuple[np.ndarray, np.ndarray]:
    """Tangents (m/s) at the start and the end of each segment."""
    secant = np.diff(points, axis=0) / np.diff(times)[:, None]
    if obstacle.interpolation == "linear":
        return secant, secant
    # Catmull-Rom on uneven times: the tangent at an inner keyframe is the chord of its neighbours.
    inner = (points[2:] - points[:-2]) / (times[2:] - times[:-2])[:, None]
    first, last = secant[:1], secant[-1:]
    if obstacle.loop and np.array_equal(points[0], points[-1]):
        # A closed path: the ends are one keyframe, and its tangent spans the wrap.
        first = last = (points[1:2] - points[-2:-1]) / (times[1] - times[0] + times[-1] - times[-2])
    at = np.concatenate([first, inner, last])
    return at[:-1], at[1:]


class MovingTracks:
    """The obstacles' keyframes as tables of cubic polynomials, evaluated all at once with states(t).

    Row i of the tables has a resting segment before the first keyframe, one segment per pair of
    keyframes and a resting one after the last, so the segment of time tau is simply the number of
    keyframe times <= tau, with no special cases.
    """

    def __init__(self, obstacles: Sequence[MovingObstacle]):
        n, k = len(obstacles), max((len(o.keyframes) for o in obstacles), default=2)
        self.count = n
        self._times = np.full((n, k), np.inf)        # padding past the last keyframe is never reached
        self._starts = np.zeros((n, k + 1))          # start time of each segment
        self._coef = np.zeros((n, k + 1, 4, 2))      # position = sum of coef[j] * u**j, u = tau - start
        for i, obstacle in enumerate(obstacles):
            frames = np.asarray(obstacle.keyframes, dtype=float)
            times, points, m = frames[:, 0], frames[:, 1:], len(frames)
            h = np.diff(times)[:, None]
            m0, m1 = _tangents(times, points, obstacle)
            chord = np.diff(points, axis=0) / h
            self._times[i, :m] = times
            self._starts[i, :m + 1] = np.r_[times[0], times]
            self._coef[i, 0, 0], self._coef[i, m, 0] = points[0], points[-1]
            self._coef[i, 1:m] = np.stack([points[:-1], m0, (3 * chord - 2 * m0 - m1) / h,
                                           (m0 + m1 - 2 * chord) / h ** 2], axis=1)
        self._t0 = self._times[:, 0]
        self._t_end = np.array([o.keyframes[-1][0] for o in obstacles], dtype=float)
        self._phase = np.array([o.phase for o in obstacles], dtype=float)
        self._loop = np.array([o.loop for o in obstacles], dtype=bool)
        self._rows = np.arange(n)
        self._cylinders = np.array([o.shape == "cylinder" for o in obstacles], dtype=bool)
        self._radius = np.array([o.radius for o in obstacles], dtype=float)
        self._half_size = np.array([o.size for o in obstacles], dtype=float).reshape(n, 2) / 2
        self._height = np.array([o.height for o in obstacles], dtype=float)
        self.reach = np.array([o.bounding_radius() for o in obstacles], dtype=float)

    def states(self, t: float) -> np.ndarray:
        """(n, 4) array of x, y, vx, vy of every obstacle at sim time t."""
        tau = t - self._phase
        wraps = self._loop & (tau >= self._t_end)
        if wraps.any():
            tau = np.where(wraps, self._t0 + np.mod(tau - self._t0, self._t_end - self._t0), tau)
        seg = (self._times <= tau[:, None]).sum(axis=1)
        u = (tau - self._starts[self._rows, seg])[:, None]
        c0, c1, c2, c3 = np.moveaxis(self._coef[self._rows, seg], 1, 0)
        return np.hstack((c0 + u * (c1 + u * (c2 + u * c3)), c1 + u * (2 * c2 + 3 * u * c3)))

    def ray_fractions(self, origins: np.ndarray, ends: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Where each ray (rows of origins -> ends, world frame) first enters an obstacle whose centre is
        at ``xy``, as a fraction of its length; inf for none. A ray starting inside an obstacle does not
        see it, as in Bullet, and a hit counts only between the floor and the obstacle's height."""
        best = np.full(len(origins), np.inf)
        low, high = np.minimum(origins, ends).min(axis=0)[:2], np.maximum(origins, ends).max(axis=0)[:2]
        near = np.all((xy + self.reach[:, None] >= low) & (xy - self.reach[:, None] <= high), axis=1)
        delta = ends - origins
        for subset, enter in ((near & self._cylinders, _circle_entry), (near & ~self._cylinders, _box_entry)):
            if subset.any():
                # (rays, obstacles) arrays of the origin relative to each centre, and the direction
                rx, ry = origins[:, :1] - xy[subset, 0], origins[:, 1:2] - xy[subset, 1]
                s = enter(rx, ry, delta[:, :1], delta[:, 1:2], self._radius[subset], self._half_size[subset])
                z = origins[:, 2:3] + s * delta[:, 2:3]
                s[(s > 1) | (z < 0) | (z > self._height[subset])] = np.inf
                best = np.minimum(best, s.min(axis=1))
        return best


def _circle_entry(rx, ry, dx, dy, radius, _half_size) -> np.ndarray:
    """Fraction at which each ray enters each circle, inf if it misses or starts inside."""
    a = dx * dx + dy * dy
    b = rx * dx + ry * dy
    c = rx * rx + ry * ry - radius * radius
    disc = b * b - a * c
    hits = (disc >= 0) & (c > 0) & (b < 0)       # outside, pointing towards the centre, line meets the circle
    s = np.full(disc.shape, np.inf)
    s[hits] = ((-b - np.sqrt(np.where(hits, disc, 0.0))) / a)[hits]
    return s


def _box_entry(rx, ry, dx, dy, _radius, half_size) -> np.ndarray:
    """Fraction at which each ray enters each axis-aligned rectangle (slab test), inf if it misses or
    starts inside."""
    hx, hy = half_size[:, 0], half_size[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        x1, x2 = (-hx - rx) / dx, (hx - rx) / dx
        y1, y2 = (-hy - ry) / dy, (hy - ry) / dy
    t_near = np.fmax(np.minimum(x1, x2), np.minimum(y1, y2))
    t_far = np.fmin(np.maximum(x1, x2), np.maximum(y1, y2))
    inside = (np.abs(rx) <= hx) & (np.abs(ry) <= hy)
    return np.where((t_near <= t_far) & (t_near >= 0) & ~inside, t_near, np.inf)
