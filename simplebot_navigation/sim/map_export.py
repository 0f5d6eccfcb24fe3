"""A world as a map_server map: its static obstacles rasterised, exact or made to look like a SLAM map.

    python -m simplebot_navigation.sim.map_export WORLD --resolution 0.05 --out office.yaml [--noisy SEED]

WORLD is anything ``--world`` takes (a built-in name, ``forest:N``, a world or map file). The map covers the
world's obstacles, start and goals plus ``MARGIN_M``, its origin on a multiple of the resolution; a cell is
occupied (100) when a wall, box or cylinder overlaps it with positive area, free (0) when the robot could reach it
from the world's start, and unknown (-1) otherwise (beyond the outer walls, inside closed furniture), as a mapping
run leaves what it never saw. Moving obstacles are never exported. The noisy rule is in ``export_map`` and docs/reference.md §7.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

from simplebot_navigation.maps.cli import OneLineParser
from simplebot_navigation.maps.images import check_size
from simplebot_navigation.maps.map_io import OccupancyMap, save_map
from simplebot_navigation.sim.world import Box, Cylinder, World
from simplebot_navigation.sim.world_loader import load_world

MARGIN_M = 1.0
MIN_RESOLUTION, MAX_RESOLUTION = 0.01, 1.0
#: noisy maps: a box or cylinder of at most this footprint is furniture that a fifth of may be missing
FURNITURE_AREA_M2 = 1.0
#: noisy maps: the grid is cut into squares of this side, and in this share of them the walls grow a cell
WALL_TILE_M = 1.0
WALL_TILE_SHARE = 0.3
#: overlap thinner than this (m) does not count: a wall ending on a cell boundary leaves the next cell free
_EPS = 1e-9


def export_map(world: World, resolution: float, noisy_seed: int | None = None) -> OccupancyMap:
    """The world's static obstacles as an OccupancyMap (100 occupied, 0 free where reachable from the start,
    -1 unknown elsewhere).

    With ``noisy_seed`` the map is what a SLAM run might give, the same for the same seed: of the small
    free-standing obstacles (boxes and cylinders of footprint <= FURNITURE_AREA_M2) a fifth, rounded up, is
    left out, chosen at random; and the free cells beside a wall (4-neighbours) become occupied in a random
    WALL_TILE_SHARE of the WALL_TILE_M squares of the grid, so walls are a cell thicker along stretches."""
    if isinstance(resolution, bool) or not isinstance(resolution, (int, float)) \
            or not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise ValueError(f"resolution must be {MIN_RESOLUTION} to {MAX_RESOLUTION} m per cell, got {resolution!r}")
    if noisy_seed is not None and (isinstance(noisy_seed, bool) or not isinstance(noisy_seed, int) or noisy_seed < 0):
        raise ValueError(f"noisy seed must be a whole number >= 0, got {noisy_seed!r}")
    xmin, ymin, xmax, ymax = world.bounds()
    col0, row0 = math.floor((xmin - MARGIN_M) / resolution), math.floor((ymin - MARGIN_M) / resolution)
    width = math.ceil((xmax + MARGIN_M) / resolution) - col0
    height = math.ceil((ymax + MARGIN_M) / resolution) - row0
    check_size(width, height, f"world {world.name} at {resolution} m per cell")
    grid = _Grid(col0 * resolution, row0 * resolution, resolution, np.zeros((height, width), dtype=bool))

    rng = np.random.default_rng(noisy_seed) if noisy_seed is not None else None
    furniture = [shape for shape in (*world.boxes, *world.cylinders) if _area(shape) <= FURNITURE_AREA_M2]
    missing = set() if rng is None else \
        {int(i) for i in rng.choice(len(furniture), (len(furniture) + 4) // 5, replace=False)}
    for index, shape in enumerate(furniture):
        if index not in missing:
            grid.fill(shape)
    for shape in (*world.boxes, *world.cylinders):
        if _area(shape) > FURNITURE_AREA_M2:
            grid.fill(shape)
    walls = _Grid(grid.x0, grid.y0, resolution, np.zeros_like(grid.occupied))
    for wall in world.walls:
        walls.fill(wall.as_box())
    if rng is not None:
        _thicken(walls.occupied, grid.occupied | walls.occupied, rng, max(1, round(WALL_TILE_M / resolution)))
    occupied = grid.occupied | walls.occupied
    data = np.where(occupied, 100, 0).astype(np.int8)
    data[~occupied & ~_reachable(~occupied, grid, world.start)] = -1
    return OccupancyMap(data, float(resolution), (grid.x0, grid.y0, 0.0))


def _reachable(free: np.ndarray, grid: "_Grid", start) -> np.ndarray:
    """The free cells 4-connected to the start's cell (all free cells if the start's cell is not free)."""
    labels, _ = ndimage.label(free)
    row, col = int((start.y - grid.y0) / grid.resolution), int((start.x - grid.x0) / grid.resolution)
    inside = 0 <= row < free.shape[0] and 0 <= col < free.shape[1]
    if not inside or labels[row, col] == 0:
        return free
    return labels == labels[row, col]


def _area(shape: Box | Cylinder) -> float:
    return math.pi * shape.radius ** 2 if isinstance(shape, Cylinder) else shape.size[0] * shape.size[1]


class _Grid:
    """A boolean grid with its lower-left corner at (x0, y0); row 0 at the bottom."""

    def __init__(self, x0: float, y0: float, resolution: float, occupied: np.ndarray):
        self.x0, self.y0, self.resolution, self.occupied = x0, y0, resolution, occupied

    def fill(self, shape: Box | Cylinder) -> None:
        """Mark every cell the shape overlaps (separating axes for boxes, nearest point for cylinders)."""
        if isinstance(shape, Cylinder):
            ex = ey = shape.radius
        else:
            c, s = abs(math.cos(shape.yaw)), abs(math.sin(shape.yaw))
            hx, hy = shape.size[0] / 2, shape.size[1] / 2
            ex, ey = c * hx + s * hy, s * hx + c * hy
        cx, cy = shape.center
        rows, cols = self._span(cy - ey, cy + ey, self.y0, 0), self._span(cx - ex, cx + ex, self.x0, 1)
        if rows.start >= rows.stop or cols.start >= cols.stop:
            return
        half = self.resolution / 2
        dx = (self.x0 + (np.arange(cols.start, cols.stop) + 0.5) * self.resolution - cx)[None, :]
        dy = (self.y0 + (np.arange(rows.start, rows.stop) + 0.5) * self.resolution - cy)[:, None]
        if isinstance(shape, Cylinder):
            nearest = np.hypot(np.maximum(np.abs(dx) - half, 0.0), np.maximum(np.abs(dy) - half, 0.0))
            inside = nearest < shape.radius - _EPS
        else:
            cos, sin = math.cos(shape.yaw), math.sin(shape.yaw)
            reach = half * (abs(cos) + abs(sin))       # the cell's half extent along the box's axes
            inside = ((np.abs(dx) < half + ex - _EPS) & (np.abs(dy) < half + ey - _EPS)
                      & (np.abs(dx * cos + dy * sin) < hx + reach - _EPS)
                      & (np.abs(dy * cos - dx * sin) < hy + reach - _EPS))
        self.occupied[rows, cols] |= inside

    def _span(self, low: float, high: float, start: float, axis: int) -> slice:
        """The cells (one more each side, for rounding) from low to high along an axis."""
        first = math.floor((low - start) / self.resolution) - 1
        last = math.ceil((high - start) / self.resolution) + 1
        return slice(max(first, 0), min(last, self.occupied.shape[axis]))


def _thicken(walls: np.ndarray, occupied: np.ndarray, rng: np.random.Generator, tile: int) -> None:
    """Occupy the free 4-neighbours of wall cells within the randomly chosen tiles."""
    beside = np.zeros_like(walls)
    beside[1:, :] |= walls[:-1, :]
    beside[:-1, :] |= walls[1:, :]
    beside[:, 1:] |= walls[:, :-1]
    beside[:, :-1] |= walls[:, 1:]
    rows, cols = walls.shape
    chosen = rng.random((-(-rows // tile), -(-cols // tile))) < WALL_TILE_SHARE
    in_chosen = np.repeat(np.repeat(chosen, tile, axis=0), tile, axis=1)[:rows, :cols]
    walls |= beside & ~occupied & in_chosen


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog="python -m simplebot_navigation.sim.map_export",
                           description="a world's static obstacles as a map_server map (YAML + PGM)")
    parser.add_argument("world", help="a built-in world, forest:<seed>, crowd:<seed>, people:<seed>, or a file")
    parser.add_argument("--resolution", type=float, default=0.05,
                        help=f"metres per cell, {MIN_RESOLUTION} to {MAX_RESOLUTION} (default 0.05)")
    parser.add_argument("--out", required=True, type=Path, help="the map's YAML file; the PGM goes beside it")
    parser.add_argument("--noisy", type=int, metavar="SEED", help="a SLAM-like variant, the same for the same seed")
    args = parser.parse_args(argv)
    prog = "map_export"
    if args.out.suffix not in (".yaml", ".yml"):
        return _fail(prog, f"--out {args.out}: the file name must end in .yaml")
    if not args.out.parent.is_dir():
        return _fail(prog, f"--out {args.out}: folder {args.out.parent} does not exist")
    try:
        world = load_world(args.world)
        occupancy_map = export_map(world, args.resolution, args.noisy)
    except ValueError as err:
        return _fail(prog, str(err))
    try:
        image = save_map(occupancy_map, args.out)
    except OSError as err:
        return _fail(prog, f"--out {args.out}: {err.strerror or err}", code=1)
    variant = f", noisy seed {args.noisy}" if args.noisy is not None else ""
    print(f"{prog}: wrote {args.out} and {image.name}: {world.name}, {occupancy_map.width} x "
          f"{occupancy_map.height} cells of {occupancy_map.resolution} m{variant}")
    return 0


def _fail(prog: str, message: str, code: int = 2) -> int:
    print(f"{prog}: {message}", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
