"""Import a map_server map (map.yaml + PGM/PNG) as a world: occupied cells extruded to boxes.

The map is read by maps/map_io.py with map_server's semantics; an occupied cell is one of value 100
(in raw mode, one of at least occupied_thresh * 100). The YAML may also carry the world keys ``name``,
``start``, ``goals`` and ``height`` (extrusion height, default 1.0 m). Runs of occupied cells are merged
into rectangles so a wall becomes a handful of boxes, not one per cell.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import MappingProxyType

import numpy as np

from simplebot_navigation.maps.map_io import MAP_KEYS, decode_map, parse_map_yaml
from simplebot_navigation.sim.world import DEFAULT_HEIGHT, Box, World, world_from_dict

WORLD_KEYS = ("name", "start", "goals", "height")


def world_from_map(data: dict, path: Path):
    source = path.name
    meta = parse_map_yaml(data, path, extra_keys=WORLD_KEYS)
    height = data.get("height", DEFAULT_HEIGHT)
    if isinstance(height, bool) or not isinstance(height, (int, float)) or not math.isfinite(height) or height <= 0:
        raise ValueError(f"{source}: height: expected a positive number, got {height!r}")
    cells = decode_map(meta).data
    occupied = cells >= meta.occupied_thresh * 100 if meta.mode == "raw" else cells == 100

    resolution = meta.resolution
    ox, oy, oyaw = meta.origin
    c, s = math.cos(oyaw), math.sin(oyaw)
    boxes = []
    for row0, row1, col0, col1 in occupied_rectangles(occupied):
        # Row 0 is the bottom row; the origin is the lower-left cell's corner.
        lx = (col0 + col1) / 2 * resolution
        ly = (row0 + row1) / 2 * resolution
        boxes.append(Box((ox + c * lx - s * ly, oy + s * lx + c * ly),
                         ((col1 - col0) * resolution, (row1 - row0) * resolution), oyaw, float(height)))

    world_data = {k: data[k] for k in ("start", "goals") if k in data}
    world_data["name"] = data.get("name", path.stem)
    world = world_from_dict(world_data, source=source, default_name=path.stem)
    extra = MappingProxyType({"map": {k: data[k] for k in MAP_KEYS if k in data}})
    return World(world.name, (), tuple(boxes), (), world.start, world.goals, source, extra)


def occupied_rectangles(mask: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Cover a boolean image with rectangles (row0, row1, col0, col1), half-open.

    Horizontal runs of each row are merged with identical runs of the rows below, which turns
    axis-aligned walls into single boxes.
    """
    rects = []
    open_runs: dict[tuple[int, int], int] = {}
    for row in range(mask.shape[0] + 1):
        runs = set(_runs(mask[row])) if row < mask.shape[0] else set()
        for run in list(open_runs):
            if run not in runs:
                rects.append((open_runs.pop(run), row, *run))
        for run in runs:
            open_runs.setdefault(run, row)
    return sorted(rects)


def _runs(line: np.ndarray) -> list[tuple[int, int]]:
    padded = np.concatenate(([False], line, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))
