"""What the viewer draws, kept as numpy arrays, and its binary encoding for the page.

The ROS node fills a Scene from its callbacks (cheap copies, no drawing work);
the HTTP server encodes it at a bounded rate, so a slow or absent browser never
costs the navigation nodes anything. Data stays in the frame it came in and is
put into the fixed frame at encoding time, when the transform has arrived.

Frame layout (little endian): uint32 length of a UTF-8 JSON header, the header,
zero padding to a multiple of 8, then the binary buffers the header lists by
offset (relative to the binary section, each 8-byte aligned).
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable

import numpy as np

from simplebot_navigation.geometry import transform_points

Pose2D = tuple[float, float, float]
#: lookup(frame_id, stamp_ns) -> pose of frame_id in the fixed frame, or None when unknown; stamp 0 = latest
Lookup = Callable[[str, int], "Pose2D | None"]

#: costmap cells sent for unknown space (OccupancyGrid -1); 0..100 are sent as they are
UNKNOWN_CELL = 255
TRAIL_STEP_M = 0.02
LOG_LINES = 8


@dataclass
class Grid:
    """An OccupancyGrid (values -1..100, [row=y, col=x]) in its own frame."""

    cells: np.ndarray
    resolution: float
    origin: Pose2D
    frame: str
    version: int


@dataclass
class Scan:
    frame: str
    stamp_ns: int
    angles: np.ndarray
    ranges: np.ndarray


@dataclass
class Poses:
    """A path, pose array, polygon or single pose: (N, 2) points or (N, 3) x, y, yaw rows in frame."""

    frame: str
    stamp_ns: int
    values: np.ndarray


def downsample_grid(cells: np.ndarray, max_side: int) -> tuple[np.ndarray, int]:
    """Grid as uint8 (unknown = 255) at most max_side cells a side, and the factor used.

    Blocks keep their highest known cost, so thin walls and lethal cells never vanish
    from the picture; a block is unknown only if all of its cells are.
    """
    h, w = cells.shape
    factor = max(1, math.ceil(max(h, w) / max_side))
    if factor > 1:
        ph, pw = -h % factor, -w % factor
        padded = np.pad(cells, ((0, ph), (0, pw)), constant_values=-1)
        cells = padded.reshape(padded.shape[0] // factor, factor, padded.shape[1] // factor, factor).max(axis=(1, 3))
    out = cells.astype(np.uint8)  # -1 wraps to 255
    out[cells < 0] = UNKNOWN_CELL
    return out, factor


def obstacle_outlines(shapes: list[tuple[bool, float, float, float, float, float]], sides: int = 24) -> np.ndarray:
    """Closed outlines of (is_cylinder, x, y, yaw, size_x, size_y) shapes as (N, 2) points, one NaN row after
    each outline, for the page's polyline to lift the pen: the moving obstacles' markers."""
    rows = []
    for cylinder, x, y, yaw, sx, sy in shapes:
        if cylinder:
            angles = np.linspace(0.0, 2 * math.pi, sides + 1)
            local = np.column_stack((np.cos(angles) * sx / 2, np.sin(angles) * sy / 2))
        else:
            local = np.array([(1, 1), (-1, 1), (-1, -1), (1, -1), (1, 1)]) * (sx / 2, sy / 2)
        rows += [transform_points((x, y, yaw), local), np.full((1, 2), np.nan)]
    return np.concatenate(rows) if rows else np.zeros((0, 2))


def to_frame(pose: Pose2D, points: np.ndarray) -> np.ndarray:
    """(N, 2) points or (N, 3) poses given in a frame whose pose in the fixed frame is pose, as float32."""
    return transform_points(pose, points, dtype=np.float32)


class Scene:
    """Latest state of every displayed topic; thread safe (ROS callbacks write, HTTP threads encode)."""

    def __init__(self, fixed_frame: str = "odom", max_costmap_side: int = 400, costmap_period_s: float = 0.2,
                 trail_points: int = 5000):
        if max_costmap_side < 16:
            raise ValueError(f"viewer parameter 'max_costmap_side' must be >= 16, got {max_costmap_side}")
        if trail_points < 2:
            raise ValueError(f"viewer parameter 'trail_points' must be >= 2, got {trail_points}")
        self.fixed_frame = fixed_frame
        self.max_costmap_side = max_costmap_side
        self.costmap_period_s = costmap_period_s
        self.trail_points = trail_points
        self.changed = threading.Condition()
        self.version = 0
        self.grids: dict[str, Grid] = {}
        self.scans: dict[str, Scan] = {}
        self.paths: dict[str, Poses] = {}
        self.goal: Poses | None = None
        self.body: list[np.ndarray] = []
        self.body_version = 0
        self.trail: list[tuple[float, float]] = []
        self.velocity = (0.0, 0.0)
        self.command = (0.0, 0.0)
        self.status: dict = {}
        self.log: deque = deque(maxlen=LOG_LINES)
        self.recoveries = {"count": 0, "last": None}
        self.sim_time = None
        self._clock_samples: deque = deque()
        self._grid_versions = 0
        # name -> (grid version encoded, wall time, meta, bytes)
        self._encoded_grids: dict[str, tuple[int, float, dict, bytes]] = {}

    # -- writers (ROS callbacks) ---------------------------------------------------------------
    def _touch(self) -> None:
        self.version += 1
        self.changed.notify_all()

    def set_grid(self, name: str, cells: np.ndarray, resolution: float, origin: Pose2D, frame: str) -> None:
        if cells.ndim != 2 or cells.size == 0:
            raise ValueError(f"costmap {name}: grid must be a non-empty 2-D array, got shape {cells.shape}")
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"costmap {name}: resolution must be positive, got {resolution}")
        with self.changed:
            self._grid_versions += 1
            self.grids[name] = Grid(np.array(cells, dtype=np.int8), float(resolution), origin, frame,
                                    self._grid_versions)
            self._touch()

    def update_grid(self, name: str, x: int, y: int, cells: np.ndarray) -> None:
        """costmap_updates: a window of cells at column x, row y of the last full grid."""
        with self.changed:
            grid = self.grids.get(name)
            if grid is None:
                raise ValueError(f"costmap {name}: an update arrived before any full costmap")
            h, w = cells.shape
            if x < 0 or y < 0 or y + h > grid.cells.shape[0] or x + w > grid.cells.shape[1]:
                raise ValueError(f"costmap {name}: update window x={x} y={y} {w}x{h} lies outside the "
                                 f"{grid.cells.shape[1]}x{grid.cells.shape[0]} grid")
            grid.cells[y:y + h, x:x + w] = cells
            self._grid_versions += 1
            grid.version = self._grid_versions
            self._touch()

    def set_scan(self, name: str, frame: str, stamp_ns: int, angle_min: float, angle_increment: float,
                 ranges: np.ndarray, range_min: float, range_max: float) -> None:
        ranges = np.asarray(ranges, dtype=np.float32)
        angles = angle_min + angle_increment * np.arange(ranges.size, dtype=np.float32)
        valid = np.isfinite(ranges) & (ranges >= range_min) & (ranges <= range_max)
        with self.changed:
            self.scans[name] = Scan(frame, stamp_ns, angles[valid], ranges[valid])
            self._touch()

    def set_poses(self, name: str, frame: str, stamp_ns: int, values: np.ndarray) -> None:
        with self.changed:
            self.paths[name] = Poses(frame, stamp_ns, np.asarray(values, dtype=np.float32))
            self._touch()

    def set_goal(self, frame: str, stamp_ns: int, pose: Pose2D) -> None:
        with self.changed:
            self.goal = Poses(frame, stamp_ns, np.array([pose], dtype=np.float32))
            self._touch()

    def set_body(self, outlines: list[np.ndarray]) -> None:
        with self.changed:
            self.body = [np.asarray(o, dtype=np.float32) for o in outlines]
            self.body_version += 1
            self._touch()

    def set_odometry(self, x: float, y: float, v: float, w: float) -> None:
        """Odometry in the fixed frame: speeds for the panel, positions for the trail."""
        with self.changed:
            self.velocity = (v, w)
            if not self.trail or math.hypot(x - self.trail[-1][0], y - self.trail[-1][1]) >= TRAIL_STEP_M:
                self.trail.append((x, y))
                if len(self.trail) > self.trail_points:
                    self.trail = self.trail[::2]  # halve the density, keep the whole run
            self._touch()

    def set_command(self, v: float, w: float) -> None:
        with self.changed:
            self.command = (v, w)
            self._touch()

    def set_clock(self, sim_s: float, wall_s: float | None = None) -> None:
        wall_s = time.monotonic() if wall_s is None else wall_s
        with self.changed:
            self.sim_time = sim_s
            samples = self._clock_samples
            samples.append((wall_s, sim_s))
            while len(samples) > 2 and samples[0][0] < wall_s - 2.0:
                samples.popleft()
            if samples[-1][1] < samples[0][1]:  # the clock went back (a restarted simulator)
                samples.clear()
                samples.append((wall_s, sim_s))
            self._touch()

    def set_status(self, status: dict) -> None:
        with self.changed:
            self.status = status
            self._touch()

    def add_log(self, level: str, name: str, text: str) -> None:
        with self.changed:
            self.log.append({"level": level, "node": name, "text": text})
            self._touch()

    def set_recoveries(self, count: int, last: str | None) -> None:
        """move_base's recovery count since it started, and the latest one."""
        with self.changed:
            if self.recoveries != {"count": count, "last": last}:
                self.recoveries = {"count": count, "last": last}
                self._touch()

    # -- reader (HTTP threads) -----------------------------------------------------------------
    def wait_newer(self, version: int, timeout_s: float) -> int:
        with self.changed:
            self.changed.wait_for(lambda: self.version > version, timeout=timeout_s)
            return self.version

    def real_time_factor(self) -> float | None:
        samples = self._clock_samples
        if len(samples) < 2 or samples[-1][0] - samples[0][0] < 0.2:
            return None
        return (samples[-1][1] - samples[0][1]) / (samples[-1][0] - samples[0][0])

    def _encoded_grid(self, name: str, grid: Grid, lookup: Lookup, now: float) -> tuple[dict, bytes] | None:
        cached = self._encoded_grids.get(name)
        if cached is not None and (cached[0] == grid.version or now - cached[1] < self.costmap_period_s):
            return cached[2], cached[3]
        placed = lookup(grid.frame, 0)
        if placed is None:
            return None if cached is None else (cached[2], cached[3])
        cells, factor = downsample_grid(grid.cells, self.max_costmap_side)
        ox, oy, oyaw = grid.origin
        origin = to_frame(placed, np.array([[ox, oy, oyaw]]))[0]
        meta = {"version": grid.version, "width": int(cells.shape[1]), "height": int(cells.shape[0]),
                "resolution": grid.resolution * factor, "origin": [float(v) for v in origin],
                "full_width": int(grid.cells.shape[1]), "full_height": int(grid.cells.shape[0])}
        self._encoded_grids[name] = (grid.version, now, meta, cells.tobytes())
        return meta, cells.tobytes()

    def encode(self, lookup: Lookup, known: dict[str, int], base_frame: str = "base_link") -> bytes:
        """One frame for a page that already holds the costmap/body versions in known."""
        now = time.monotonic()
        buffers: list[bytes] = []
        listing: list[dict] = []

        def add(name: str, dtype: str, data: bytes) -> int:
            offset = sum(len(b) for b in buffers)
            listing.append({"name": name, "type": dtype, "offset": offset, "bytes": len(data)})
            buffers.append(data + b"\0" * (-len(data) % 8))
            return len(listing) - 1

        with self.changed:
            header: dict = {"version": self.version, "frame": self.fixed_frame, "sim_time": self.sim_time,
                            "rtf": self.real_time_factor(), "velocity": list(self.velocity),
                            "command": list(self.command), "status": self.status, "log": list(self.log),
                            "recoveries": self.recoveries,
                            "missing": [], "costmaps": {}, "layers": {}}
            robot = lookup(base_frame, 0)
            header["robot"] = None if robot is None else [float(v) for v in robot]
            if robot is None:
                header["missing"].append(f"{self.fixed_frame} -> {base_frame}")
            if self.body and known.get("body") != self.body_version:
                header["body"] = {"version": self.body_version,
                                  "outlines": [add("body", "f32", o.tobytes()) for o in self.body]}
            for name, grid in self.grids.items():
                encoded = self._encoded_grid(name, grid, lookup, now)
                if encoded is None:
                    header["missing"].append(f"{self.fixed_frame} -> {grid.frame}")
                    continue
                meta, cells = encoded
                entry = dict(meta)
                if known.get(name) != meta["version"]:
                    entry["buffer"] = add(name, "u8", cells)
                header["costmaps"][name] = entry
            for name, scan in self.scans.items():
                placed = lookup(scan.frame, scan.stamp_ns)
                if placed is None:
                    header["missing"].append(f"{self.fixed_frame} -> {scan.frame}")
                    continue
                local = np.stack([scan.ranges * np.cos(scan.angles), scan.ranges * np.sin(scan.angles)], axis=1)
                points = to_frame(placed, local)
                header["layers"][name] = {"buffer": add(name, "f32", points.tobytes()), "stride": 2,
                                          "origin": [float(placed[0]), float(placed[1])]}
            for name, poses in list(self.paths.items()) + ([("goal", self.goal)] if self.goal else []):
                placed = lookup(poses.frame, 0) if poses.frame != self.fixed_frame else (0.0, 0.0, 0.0)
                if placed is None:
                    header["missing"].append(f"{self.fixed_frame} -> {poses.frame}")
                    continue
                values = to_frame(placed, poses.values) if len(poses.values) else poses.values
                header["layers"][name] = {"buffer": add(name, "f32", values.tobytes()),
                                          "stride": int(poses.values.shape[1]) if poses.values.ndim == 2 else 3}
            if self.trail:
                header["layers"]["trail"] = {"buffer": add("trail", "f32",
                                                           np.asarray(self.trail, np.float32).tobytes()),
                                             "stride": 2}
        header["buffers"] = listing
        text = json.dumps(header, separators=(",", ":")).encode("utf-8")
        head = len(text).to_bytes(4, "little") + text
        return head + b"\0" * (-len(head) % 8) + b"".join(buffers)
