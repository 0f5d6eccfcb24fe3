"""Moving obstacles: cylinders and boxes that follow keyframes (t, x, y) through simulated time.

A world file lists them under ``moving:`` (world.py parses the file, MovingObstacle checks the values).
Positions between keyframes are linear or Catmull-Rom ("spline"); both are evaluated as cubic Hermite
segments (linear ones with the secant as both tangents), so one vectorised evaluation, MovingTracks,
serves any mix of obstacles: the simulator evaluates all of them at every physics step.
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
    """The obstacles' keyframes padded into arrays, evaluated all at once with states(t)."""

    def __init__(self, obstacles: Sequence[MovingObstacle]):
        n, k = len(obstacles), max((len(o.keyframes) for o in obstacles), default=2)
        self.count = n
        self._times = np.full((n, k), np.inf)        # padding past the last keyframe is never reached
        self._points = np.zeros((n, k, 2))
        self._m0 = np.zeros((n, k - 1, 2))
        self._m1 = np.zeros((n, k - 1, 2))
        self._last = np.zeros(n, dtype=int)
        for i, obstacle in enumerate(obstacles):
            frames = np.asarray(obstacle.keyframes, dtype=float)
            m = len(frames)
            self._times[i, :m], self._points[i, :m] = frames[:, 0], frames[:, 1:]
            self._m0[i, :m - 1], self._m1[i, :m - 1] = _tangents(frames[:, 0], frames[:, 1:], obstacle)
            self._last[i] = m - 1
        self._phase = np.array([o.phase for o in obstacles], dtype=float)
        self._loop = np.array([o.loop for o in obstacles], dtype=bool)
        rows = np.arange(n)
        self._rows = rows
        self._t0, self._t_end = self._times[:, 0], self._times[rows, self._last]
        self._p0, self._p_end = self._points[:, 0], self._points[rows, self._last]

    def states(self, t: float) -> np.ndarray:
        """(n, 4) array of x, y, vx, vy of every obstacle at sim time t."""
        out = np.zeros((self.count, 4))
        if not self.count:
            return out
        tau = t - self._phase
        period = self._t_end - self._t0
        wraps = self._loop & (tau >= self._t_end)
        tau = np.where(wraps, self._t0 + np.mod(tau - self._t0, period), tau)
        before, after = tau < self._t0, tau >= self._t_end
        seg = np.clip((self._times <= tau[:, None]).sum(axis=1) - 1, 0, self._last - 1)
        rows = self._rows
        start, h = self._times[rows, seg], self._times[rows, seg + 1] - self._times[rows, seg]
        s = np.clip((tau - start) / h, 0.0, 1.0)[:, None]
        p0, p1 = self._points[rows, seg], self._points[rows, seg + 1]
        m0, m1 = self._m0[rows, seg] * h[:, None], self._m1[rows, seg] * h[:, None]
        s2, s3 = s * s, s * s * s
        out[:, :2] = ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0
                      + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1)
        out[:, 2:] = ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * m0
                      + (-6 * s2 + 6 * s) * p1 + (3 * s2 - 2 * s) * m1) / h[:, None]
        out[before, :2], out[before, 2:] = self._p0[before], 0.0
        out[after, :2], out[after, 2:] = self._p_end[after], 0.0
        return out
