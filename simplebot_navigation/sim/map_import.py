"""Import a map_server map (map.yaml + PGM/PNG) as a world: occupied pixels extruded to boxes.

The map YAML is read with map_server's semantics (image relative to the YAML, resolution, origin
[x, y, yaw] of the lower-left pixel, negate, occupied_thresh, mode). It may also carry the world
keys ``name``, ``start``, ``goals`` and ``height`` (extrusion height, default 1.0 m). Runs of
occupied pixels are merged into rectangles so a wall becomes a handful of boxes, not one per pixel.
PGM is parsed here; other image formats need Pillow.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from types import MappingProxyType

import numpy as np

from simplebot_navigation.sim.world import DEFAULT_HEIGHT, Box, World, world_from_dict

MAP_KEYS = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}
WORLD_KEYS = {"name", "start", "goals", "height"}


def world_from_map(data: dict, path: Path):
    source = path.name

    def fail(key, problem):
        raise ValueError(f"{source}: {key}: {problem}")

    unknown = sorted(set(data) - MAP_KEYS - WORLD_KEYS, key=str)
    if unknown:
        fail(unknown[0], f"unknown key (map keys: {', '.join(sorted(MAP_KEYS | WORLD_KEYS))})")
    for key in ("resolution", "origin"):
        if key not in data:
            fail(key, "missing (a map_server map needs image, resolution and origin)")

    def number(key, default=None, value=None):
        value = data.get(key, default) if value is None else value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            fail(key, f"expected a finite number, got {value!r}")
        return float(value)

    resolution = number("resolution")
    if resolution <= 0:
        fail("resolution", f"must be positive, got {resolution}")
    origin = data["origin"]
    if not isinstance(origin, list) or len(origin) != 3:
        fail("origin", f"expected [x, y, yaw], got {origin!r}")
    ox, oy, oyaw = (number("origin", value=v) for v in origin)
    negate = data.get("negate", 0)
    if negate not in (0, 1, False, True):
        fail("negate", f"expected 0 or 1, got {negate!r}")
    occupied_thresh = number("occupied_thresh", 0.65)
    mode = data.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        fail("mode", f"expected trinary, scale or raw, got {mode!r}")
    height = number("height", DEFAULT_HEIGHT)
    if height <= 0:
        fail("height", f"must be positive, got {height}")
    if not isinstance(data["image"], str):
        fail("image", f"expected a file name, got {data['image']!r}")
    image_path = path.parent / data["image"]
    if not image_path.is_file():
        fail("image", f"no such file {image_path}")

    pixels = read_image(image_path)
    if mode == "raw":
        occupied = (pixels >= occupied_thresh * 100) & (pixels <= 100)
    else:
        occ = pixels / 255.0 if negate else (255.0 - pixels) / 255.0
        occupied = occ > occupied_thresh

    c, s = math.cos(oyaw), math.sin(oyaw)
    rows = pixels.shape[0]
    boxes = []
    for row0, row1, col0, col1 in occupied_rectangles(occupied):
        # Image row 0 is the top of the map; the origin is the lower-left pixel's corner.
        lx = (col0 + col1) / 2 * resolution
        ly = (rows - (row0 + row1) / 2) * resolution
        boxes.append(Box((ox + c * lx - s * ly, oy + s * lx + c * ly),
                         ((col1 - col0) * resolution, (row1 - row0) * resolution), oyaw, height))

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


def read_image(path: Path) -> np.ndarray:
    """Grey values 0..255 as a 2-D array, colour averaged over the channels like map_server."""
    if path.suffix.lower() == ".pgm":
        return _read_pgm(path)
    try:
        from PIL import Image
    except ImportError as exc:
        raise ValueError(f"{path.name}: reading {path.suffix} images needs Pillow; "
                         f"install it or convert the map to PGM") from exc
    with Image.open(path) as img:
        arr = np.asarray(img.convert("RGBA") if img.mode in ("P", "LA", "PA") else img, dtype=float)
    if arr.ndim == 3:
        channels = 3 if arr.shape[2] >= 3 else 1
        arr = arr[:, :, :channels].mean(axis=2)
    return arr


def _read_pgm(path: Path) -> np.ndarray:
    raw = path.read_bytes()
    # Header: magic, width, height, maxval, separated by whitespace; comments run from # to EOL.
    tokens = []
    pos = 0
    token_re = re.compile(rb"\s*(?:#[^\n]*\n\s*)*(\S+)")
    for _ in range(4):
        m = token_re.match(raw, pos)
        if m is None:
            raise ValueError(f"{path.name}: truncated PGM header")
        tokens.append(m.group(1))
        pos = m.end()
    magic, width, height, maxval = tokens[0], *tokens[1:]
    if magic not in (b"P2", b"P5"):
        raise ValueError(f"{path.name}: not a greyscale PGM (magic {magic!r}, expected P2 or P5)")
    try:
        width, height, maxval = int(width), int(height), int(maxval)
    except ValueError as exc:
        raise ValueError(f"{path.name}: bad PGM header {tokens!r}") from exc
    if width <= 0 or height <= 0 or not 0 < maxval < 65536:
        raise ValueError(f"{path.name}: bad PGM header {tokens!r}")
    count = width * height
    if magic == b"P5":
        dtype = np.uint8 if maxval < 256 else np.dtype(">u2")
        data = np.frombuffer(raw, dtype=dtype, count=count, offset=pos + 1) \
            if len(raw) >= pos + 1 + count * np.dtype(dtype).itemsize else None
    else:
        values = raw[pos:].split()
        data = np.array(values[:count], dtype=int) if len(values) >= count else None
    if data is None:
        raise ValueError(f"{path.name}: PGM has fewer than {width} x {height} pixels")
    return data.reshape(height, width).astype(float) * (255.0 / maxval)
