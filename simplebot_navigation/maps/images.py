"""Map images: PGM (P2 and P5, 8 and 16 bit) parsed here, other formats through Pillow.

An image comes back as grey *levels*, unsigned integers with row 0 at the image's top, plus the level
of white: a decoder then works on a table of every possible level instead of a float per pixel, which
keeps a large map within a few times its cell count in bytes. A colour pixel's level is the sum of its red, green
and blue levels (white is 765), since map_server averages the colour channels (a grey pixel of an image
with alpha counts as three equal channels, as GraphicsMagick sees it). Alpha, where the image has it,
comes apart: 255 is opaque.

The size is checked from the header, before any pixel is read: at most ``MAX_SIDE`` pixels a side and
``MAX_CELLS`` in all, so a header that claims 50000 x 50000 is refused at once.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

#: the largest map image accepted, pixels per side and in all. The cell bound is what amcl and the global planner
#: handle within their budgets (docs/reference.md §7.1): 2000 x 2000 cells load into amcl in about 0.5 s and are
#: planned across in about 0.2 s; 4000 x 4000 take 2.3 s (map -> odom goes stale meanwhile) and 0.7 s a plan.
MAX_SIDE = 16384
MAX_CELLS = 4_000_000
#: a PGM header (magic, size, maxval and comments) longer than this is not a map
HEADER_BYTES = 65536
_HEADER_TOKEN = re.compile(rb"(?:\s+|#[^\r\n]*)*([^\s#]+)")
_PLAIN_PIXEL_BYTES = b"0123456789 \t\n\v\f\r"


class MapError(ValueError):
    """A map that cannot be used: one line naming the file and the key or the problem."""


@dataclass(frozen=True)
class Levels:
    levels: np.ndarray               # [rows, cols], unsigned; row 0 is the image's top
    white: int                       # the level of a white pixel
    alpha: np.ndarray | None         # [rows, cols] uint8 (255 opaque), or None when the image has no alpha


def check_size(width: int, height: int, where) -> None:
    """Refuse an image beyond MAX_SIDE a side or MAX_CELLS in all (or an empty one)."""
    if width < 1 or height < 1 or width > MAX_SIDE or height > MAX_SIDE or width * height > MAX_CELLS:
        raise MapError(f"{where}: image is {width} x {height} pixels; a map has 1 to {MAX_SIDE} a side "
                       f"and at most {MAX_CELLS} cells in all (what amcl and the global planner handle in time)")


def read_image(path: Path) -> Levels:
    """The image's grey levels: ``.pgm`` files by the parser below, anything else by Pillow."""
    if path.suffix.lower() == ".pgm":
        try:
            return read_pgm(path)
        except OSError as err:     # unreadable: a directory, no permission, an I/O error
            raise MapError(f"{path}: cannot be read ({err.strerror or err.__class__.__name__})") from None
    return _read_with_pillow(path)


# -- PGM -----------------------------------------------------------------------------------------
def read_pgm(path: Path) -> Levels:
    with open(path, "rb") as file:
        magic, width, height, maxval, start = _pgm_header(file.read(HEADER_BYTES), path)
        check_size(width, height, path)
        file.seek(start)
        itemsize = 1 if maxval < 256 else 2
        body = file.read(width * height * itemsize) if magic == b"P5" else file.read()
    if magic == b"P5":
        if len(body) < width * height * itemsize:
            raise MapError(f"{path}: PGM has fewer than {width} x {height} pixels (truncated)")
        pixels = np.frombuffer(body, np.uint8 if itemsize == 1 else np.dtype(">u2")).astype(
            np.uint8 if itemsize == 1 else np.uint16)
    else:
        pixels = _plain_pixels(body, width * height, path)
    if int(pixels.max()) > maxval:
        raise MapError(f"{path}: garbage PGM: pixel value {int(pixels.max())} above maxval {maxval}")
    return Levels(pixels.reshape(height, width), maxval, None)


def _pgm_header(head: bytes, path: Path) -> tuple[bytes, int, int, int, int]:
    """(magic, width, height, maxval, offset of the first pixel) from the file's first bytes."""
    tokens, pos = [], 0
    for _ in range(4):
        match = _HEADER_TOKEN.match(head, pos)
        if match is None:
            raise MapError(f"{path}: truncated PGM header")
        tokens.append(match.group(1))
        pos = match.end()
        if len(tokens) == 1 and tokens[0] not in (b"P2", b"P5"):
            raise MapError(f"{path}: not a greyscale PGM (magic {tokens[0][:8]!r}, expected P2 or P5)")
    if pos >= len(head):
        raise MapError(f"{path}: truncated PGM header" if len(head) < HEADER_BYTES
                       else f"{path}: garbage PGM header: longer than {HEADER_BYTES} bytes")
    numbers = []
    for name, token in zip(("width", "height", "maxval"), tokens[1:]):
        if not token.isdigit() or len(token) > 9:
            raise MapError(f"{path}: garbage PGM header: {name} {token[:16]!r} is not a whole number")
        numbers.append(int(token))
    width, height, maxval = numbers
    if not 1 <= maxval <= 65535:
        raise MapError(f"{path}: garbage PGM header: maxval {maxval} not in 1..65535")
    return tokens[0], width, height, maxval, pos + 1 if tokens[0] == b"P5" else pos


def _plain_pixels(body: bytes, count: int, path: Path) -> np.ndarray:
    """The pixels of a plain (P2) PGM: decimal numbers separated by whitespace."""
    if body.translate(None, _PLAIN_PIXEL_BYTES):
        raise MapError(f"{path}: garbage PGM: P2 pixels must be decimal numbers separated by whitespace")
    if re.search(rb"\d{6}", body):
        raise MapError(f"{path}: garbage PGM: a P2 pixel value has more than 5 digits")
    values = np.fromstring(body, dtype=np.uint32, sep=" ")
    if len(values) < count:
        raise MapError(f"{path}: PGM has fewer than {count} pixels ({len(values)}; truncated)")
    return values[:count]


def write_pgm(path: Path, grey: np.ndarray, comment: str) -> None:
    """An 8-bit binary (P5) PGM of the image rows, top row first."""
    height, width = grey.shape
    header = f"P5\n# {comment}\n{width} {height}\n255\n".encode()
    Path(path).write_bytes(header + np.ascontiguousarray(grey, dtype=np.uint8).tobytes())


# -- Pillow --------------------------------------------------------------------------------------
def _read_with_pillow(path: Path) -> Levels:
    try:
        with warnings.catch_warnings():
            # Pillow's own bound (2 x 89 M pixels) is above ours: its warning below that is ours to give.
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            image = Image.open(path)
    except Image.DecompressionBombError:
        raise MapError(f"{path}: image has more than {MAX_CELLS} pixels, the most a map may have") from None
    except (OSError, SyntaxError, ValueError) as err:
        raise MapError(f"{path}: not an image Pillow can read ({_one_line(err)})") from None
    with image:
        check_size(*image.size, path)
        try:
            return _pillow_levels(image)
        except (OSError, SyntaxError, ValueError) as err:
            raise MapError(f"{path}: the image cannot be decoded ({_one_line(err)})") from None


def _pillow_levels(image: Image.Image) -> Levels:
    if image.mode.startswith("I;16") or image.mode == "I":
        pixels = np.asarray(image)
        if pixels.size and (int(pixels.min()) < 0 or int(pixels.max()) > 65535):
            raise ValueError(f"{image.mode} pixels outside 0..65535")
        return Levels(pixels.astype(np.uint16), 65535, None)
    has_alpha = "A" in image.mode or image.mode in ("P", "PA") or "transparency" in image.info
    if image.mode in ("1", "L") and not has_alpha:
        return Levels(np.asarray(image.convert("L"), dtype=np.uint8), 255, None)
    if image.mode == "LA":
        pixels = np.asarray(image)
        return Levels(pixels[:, :, 0].astype(np.uint16) * 3, 765, np.ascontiguousarray(pixels[:, :, 1]))
    pixels = np.asarray(image.convert("RGBA" if has_alpha else "RGB"))
    levels = pixels[:, :, :3].sum(axis=2, dtype=np.uint16)
    return Levels(levels, 765, np.ascontiguousarray(pixels[:, :, 3]) if has_alpha else None)


def write_png(path: Path, grey: np.ndarray, alpha: np.ndarray) -> None:
    """A grey-and-alpha PNG of the image rows, top row first."""
    Image.fromarray(np.stack([grey, alpha], axis=2).astype(np.uint8)).save(path, format="PNG")


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__
