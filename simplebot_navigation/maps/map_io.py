"""map_server maps: a YAML file and an image, read as map_server reads them and written as map_saver writes them.

The YAML keys (docs/reference.md §7): ``image`` (relative to the YAML file), ``resolution`` (m/cell),
``origin`` ([x, y, yaw] of the lower-left pixel), ``negate``, ``occupied_thresh``, ``free_thresh`` and
``mode`` (trinary, scale or raw). The pixel rules are Nav2's map_server's (ROS 1's differ in scale and raw
mode). ``p`` is the mean of a pixel's colour channels, 0..255, and ``occ`` is ``(255 - p) / 255``
(``p / 255`` when negated):

- trinary: ``p`` also averages in the opacity when the image has alpha; occ above occupied_thresh is 100,
  below free_thresh 0, anything else -1;
- scale: a pixel not fully opaque is -1; occ above occupied_thresh 100, below free_thresh 0, in between
  ``rint(100 * (occ - free_thresh) / (occupied_thresh - free_thresh))``;
- raw: ``round(p)`` when it is 0..100, else -1; negate does not apply.

Anything wrong raises MapError with one line naming the file and the key; a bad image is named after the YAML
file and its ``image`` key, so the user knows which map's image it is.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from simplebot_navigation.maps.images import MapError, read_image, write_pgm, write_png

MODES = ("trinary", "scale", "raw")
MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
#: thresholds when the YAML has none (ROS 1 requires them): map_saver's, so that its grey 205 is unknown
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196
#: map_saver's trinary grey levels, and the thresholds its YAML declares for them
FREE_GREY, OCCUPIED_GREY, UNKNOWN_GREY = 254, 0, 205
TRINARY_YAML_THRESH = (0.65, 0.196)


@dataclass(eq=False)
class OccupancyMap:
    """A grid in nav_msgs/OccupancyGrid order: ``data[row, col]``, row 0 at the origin's y (the bottom row),
    values -1 (unknown) or 0..100."""
    data: np.ndarray
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frame_id: str = "map"

    def __post_init__(self):
        if not isinstance(self.data, np.ndarray) or self.data.dtype != np.int8 or self.data.ndim != 2:
            raise ValueError("OccupancyMap.data must be a 2-D int8 array")

    @property
    def height(self) -> int:
        return self.data.shape[0]

    @property
    def width(self) -> int:
        return self.data.shape[1]


@dataclass(frozen=True)
class MapYaml:
    """A map YAML file's keys, checked, and the file itself (``path``), which an error in the image names first."""
    path: Path
    image: Path
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str


def load_map(yaml_path: str | Path) -> OccupancyMap:
    """The map a map_server YAML file describes."""
    return decode_map(parse_map_yaml(read_yaml(yaml_path), yaml_path))


def read_yaml(yaml_path: str | Path) -> object:
    try:
        text = Path(yaml_path).read_text()
    except FileNotFoundError:
        raise MapError(f"{yaml_path}: no such file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise MapError(f"{yaml_path}: cannot be read ({err.__class__.__name__}: {err})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise MapError(f"{yaml_path}: not valid YAML: {' '.join(str(err).split())}") from None


def parse_map_yaml(data: object, yaml_path: str | Path, extra_keys: tuple[str, ...] = ()) -> MapYaml:
    """Check a parsed map YAML; ``extra_keys`` are keys a caller reads itself (a world's ``start``)."""
    def fail(key: str, problem: str):
        raise MapError(f"{yaml_path}: {key}: {problem}")

    if not isinstance(data, dict):
        raise MapError(f"{yaml_path}: expected a mapping with image, resolution and origin, got {type(data).__name__}")
    known = MAP_KEYS + tuple(extra_keys)
    for key in data:
        if key not in known:
            close = difflib.get_close_matches(str(key), known, n=1)
            fail(key, "unknown key" + (f" (did you mean {close[0]!r}?)" if close else "")
                 + f"; map keys: {', '.join(sorted(known))}")
    for key in ("image", "resolution", "origin"):
        if key not in data:
            fail(key, "missing (a map_server map needs image, resolution and origin)")

    def number(key: str, value: object) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            fail(key, f"expected a finite number, got {value!r}")
        return float(value)

    resolution = number("resolution", data["resolution"])
    if resolution <= 0:
        fail("resolution", f"must be positive, got {resolution}")
    origin = data["origin"]
    if not isinstance(origin, list) or len(origin) != 3:
        fail("origin", f"expected [x, y, yaw], got {origin!r}")
    negate = data.get("negate", 0)
    if negate not in (0, 1):
        fail("negate", f"expected 0 or 1, got {negate!r}")
    thresholds = [number(key, data.get(key, default)) for key, default in
                  (("occupied_thresh", DEFAULT_OCCUPIED_THRESH), ("free_thresh", DEFAULT_FREE_THRESH))]
    problem = threshold_problem(*thresholds)
    if problem:
        fail(*problem)
    mode = data.get("mode", "trinary")
    if mode not in MODES:
        fail("mode", f"expected trinary, scale or raw, got {mode!r}")
    image = data["image"]
    if not isinstance(image, str) or not image:
        fail("image", f"expected a file name, got {image!r}")
    image_path = Path(yaml_path).parent / image
    if not image_path.is_file():
        fail("image", f"no such file {image_path}")
    return MapYaml(Path(yaml_path), image_path, resolution, tuple(number("origin", v) for v in origin), bool(negate),
                   *thresholds, mode)


def threshold_problem(occupied_thresh: float, free_thresh: float) -> tuple[str, str] | None:
    """(key, problem) when the thresholds are not 0 <= free_thresh < occupied_thresh <= 1."""
    for key, value in (("occupied_thresh", occupied_thresh), ("free_thresh", free_thresh)):
        if not 0.0 <= value <= 1.0:
            return key, f"must be in [0, 1], got {value}"
    if free_thresh >= occupied_thresh:
        return "free_thresh", f"{free_thresh} must be below occupied_thresh {occupied_thresh}"
    return None


def decode_map(meta: MapYaml) -> OccupancyMap:
    """Read the image and turn its pixels into cells, bottom row first."""
    try:
        image = read_image(meta.image)
    except MapError as err:     # the image's own message, led by the file and key a user would edit
        raise MapError(f"{meta.path}: image: {err}") from None
    levels, white = image.levels, image.white
    if meta.mode == "trinary" and image.alpha is not None:
        levels, white = levels + image.alpha, white + 255      # the opacity as one more channel
    cells = level_table(white, meta.mode, meta.negate, meta.occupied_thresh, meta.free_thresh)[levels]
    if meta.mode == "scale" and image.alpha is not None:
        cells[image.alpha != 255] = -1
    return OccupancyMap(np.ascontiguousarray(cells[::-1]), meta.resolution, meta.origin)


def level_table(white: int, mode: str, negate: bool, occupied_thresh: float, free_thresh: float) -> np.ndarray:
    """The cell value (int8) of every grey level 0..white, by map_server's rules (module docstring)."""
    grey = np.arange(white + 1, dtype=float) * 255.0 / white
    if mode == "raw":
        value = np.floor(grey + 0.5)
        return np.where(value <= 100, value, -1).astype(np.int8)
    occupancy = grey / 255.0 if negate else (255.0 - grey) / 255.0
    table = np.full(white + 1, -1, dtype=np.int8)
    if mode == "scale":
        table[:] = np.clip(np.rint(100.0 * (occupancy - free_thresh) / (occupied_thresh - free_thresh)), -1, 100)
    table[occupancy > occupied_thresh] = 100
    table[occupancy < free_thresh] = 0
    return table


# -- writing -------------------------------------------------------------------------------------
def save_map(occupancy_map: OccupancyMap, yaml_path: str | Path, mode: str = "trinary",
             occupied_thresh: float = 0.65, free_thresh: float = 0.25) -> Path:
    """Write the YAML file and its image beside it (``name.pgm``; ``name.png`` in scale mode); the image path.

    trinary (map_saver's): a cell 0..free_thresh*100 is grey 254, occupied_thresh*100..100 is 0 (thresholds
    rounded to whole percents), anything else 205; the YAML declares ROS 1 map_saver's thresholds 0.65/0.196,
    which read exactly those three greys back (Nav2's saver writes the given ones: 0.25 reads 205 as free).
    scale: each value 0..100 a grey that the given thresholds, written to the YAML, read back as that value
    (scale_greys); unknown transparent. raw: the value itself as the grey, unknown 255. load_map gives the
    written cells back."""
    if mode not in MODES:
        raise MapError(f"{yaml_path}: mode: expected trinary, scale or raw, got {mode!r}")
    problem = threshold_problem(occupied_thresh, free_thresh)
    if problem:
        raise MapError(f"{yaml_path}: {problem[0]}: {problem[1]}")
    yaml_path = Path(yaml_path)
    image_path = yaml_path.with_suffix(".png" if mode == "scale" else ".pgm")
    cells = occupancy_map.data[::-1].astype(np.int16)           # image order: top row first
    known = (cells >= 0) & (cells <= 100)
    comment = f"CREATOR: simplebot_navigation map_saver {occupancy_map.resolution:.3f} m/pix"
    if mode == "trinary":
        grey = np.full(cells.shape, UNKNOWN_GREY, dtype=np.uint8)
        grey[known & (cells <= round(free_thresh * 100))] = FREE_GREY
        grey[known & (cells >= round(occupied_thresh * 100))] = OCCUPIED_GREY
        write_pgm(image_path, grey, comment)
        occupied_thresh, free_thresh = TRINARY_YAML_THRESH
    elif mode == "raw":
        write_pgm(image_path, np.where(known, cells, 255).astype(np.uint8), comment)
    else:
        greys = scale_greys(occupied_thresh, free_thresh)
        write_png(image_path, greys[np.where(known, cells, 0)], np.where(known, 255, 0))
    yaml_path.write_text(_yaml_text(occupancy_map, image_path.name, mode, occupied_thresh, free_thresh))
    return image_path


def scale_greys(occupied_thresh: float, free_thresh: float) -> np.ndarray:
    """For each value 0..100, a grey (uint8) that scale mode reads back as that value with these thresholds:
    white for 0, black for 100, the middle one of the greys that do for the others."""
    table = level_table(255, "scale", False, occupied_thresh, free_thresh)
    greys = np.zeros(101, dtype=np.uint8)
    for value in range(101):
        found = np.flatnonzero(table == value)
        if len(found) == 0:
            raise MapError(f"scale mode: thresholds occupied {occupied_thresh} and free {free_thresh} leave "
                           f"no grey level for the value {value}; spread them further apart")
        greys[value] = found[-1] if value == 0 else found[0] if value == 100 else found[len(found) // 2]
    return greys


def _yaml_text(occupancy_map: OccupancyMap, image_name: str, mode: str, occupied_thresh: float,
               free_thresh: float) -> str:
    """The YAML file, floats written exactly (map_saver's six decimals would move the origin)."""
    return yaml.safe_dump({
        "image": image_name, "mode": mode, "resolution": float(occupancy_map.resolution),
        "origin": [float(v) for v in occupancy_map.origin], "negate": 0,
        "occupied_thresh": float(occupied_thresh), "free_thresh": float(free_thresh)},
        sort_keys=False, default_flow_style=None)
