"""map_server maps: map_server's decoding rules, map_saver's encoding, exact round trips, and bad input refused
in one line that names the file and the key, oversized images before a pixel is read."""

from __future__ import annotations

import struct
import tracemalloc
import zlib

import numpy as np
import pytest
from PIL import Image

from simplebot_navigation.maps import MAX_CELLS, MAX_SIDE, MapError, OccupancyMap, images, load_map, save_map
from simplebot_navigation.maps.map_io import scale_greys

ORIGIN = (-3.25, 1.5000000000000002, 0.3)


def write_pgm(path, grey, maxval=255, plain=False):
    height, width = grey.shape
    header = f"P{2 if plain else 5}\n# a comment\n{width} {height}\n# another\n{maxval}\n".encode()
    if plain:
        body = "\n".join(" ".join(str(v) for v in row) for row in grey).encode() + b"\n"
    else:
        body = grey.astype(np.uint8 if maxval < 256 else ">u2").tobytes()
    path.write_bytes(header + body)


def write_yaml(tmp_path, image, **keys):
    text = f"image: {image}\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
    text += "".join(f"{key}: {value}\n" for key, value in keys.items())
    path = tmp_path / "map.yaml"
    path.write_text(text)
    return path


def load_pixels(tmp_path, grey, **keys):
    """The cells map_server makes of an 8-bit grey image (rows top first), in image order."""
    write_pgm(tmp_path / "map.pgm", np.asarray(grey))
    return load_map(write_yaml(tmp_path, "map.pgm", **keys)).data[::-1]


def random_map(rng, values, shape=(7, 11)):
    return OccupancyMap(rng.choice(np.asarray(values, dtype=np.int8), shape), 0.05, ORIGIN)


# -- decoding --------------------------------------------------------------------------------------
def test_trinary_thresholds_are_strict_and_row_0_is_the_bottom(tmp_path):
    # occupancy (255 - p) / 255: 89 -> 0.651 > 0.65; 90 -> 0.647; 205 -> 0.19608 > 0.196; 206 -> 0.192
    grey = np.array([[89, 90, 205, 206, 0, 255]], dtype=np.uint8)
    assert load_pixels(tmp_path, grey).tolist() == [[100, -1, -1, 0, 100, 0]]
    write_pgm(tmp_path / "map.pgm", np.array([[0, 0], [254, 254]], dtype=np.uint8))
    two_rows = load_map(write_yaml(tmp_path, "map.pgm")).data
    assert two_rows.tolist() == [[0, 0], [100, 100]]      # the image's top row is the grid's last


def test_negate_swaps_black_and_white(tmp_path):
    grey = np.array([[0, 255, 50, 205]], dtype=np.uint8)       # negated, occupancy is p / 255
    assert load_pixels(tmp_path, grey, negate=1).tolist() == [[0, 100, -1, 100]]


def test_scale_mode_maps_between_the_thresholds_linearly(tmp_path):
    # p = 150: occupancy 105 / 255 = 0.4118, 100 * (0.4118 - 0.25) / 0.4 = 40.4 -> 40
    grey = np.array([[150, 0, 255]], dtype=np.uint8)
    cells = load_pixels(tmp_path, grey, mode="scale", occupied_thresh=0.65, free_thresh=0.25)
    assert cells.tolist() == [[40, 100, 0]]


def test_raw_mode_takes_the_grey_itself_and_ignores_negate(tmp_path):
    grey = np.array([[42, 100, 101, 255, 0]], dtype=np.uint8)
    assert load_pixels(tmp_path, grey, mode="raw").tolist() == [[42, 100, -1, -1, 0]]
    assert load_pixels(tmp_path, grey, mode="raw", negate=1).tolist() == [[42, 100, -1, -1, 0]]


@pytest.mark.parametrize("maxval, plain", [(255, True), (65535, False), (65535, True), (1000, False)])
def test_plain_and_16_bit_pgm_read_as_the_8_bit_binary_one(tmp_path, maxval, plain):
    grey = np.array([[0, 89, 90, 205, 206, 255], [254, 153, 12, 200, 64, 128]], dtype=np.uint8)
    expected = load_pixels(tmp_path, grey, mode="scale")
    write_pgm(tmp_path / "map.pgm", np.round(grey.astype(float) * maxval / 255).astype(np.int64), maxval, plain)
    cells = load_map(write_yaml(tmp_path, "map.pgm", mode="scale")).data[::-1]
    if maxval == 1000:      # 1000 / 255 is no whole step: greys land a fraction off, thresholds as they fall
        assert np.abs(cells.astype(int) - expected).max() <= 1
    else:
        assert np.array_equal(cells, expected)


def test_png_colour_is_averaged_with_the_opacity_in_trinary_mode_only(tmp_path):
    rgba = np.array([[[0, 0, 0, 255], [254, 254, 254, 255], [255, 0, 0, 255], [255, 255, 0, 255],
                      [0, 0, 0, 0], [205, 205, 205, 255], [0, 0, 0, 128]]], dtype=np.uint8)
    Image.fromarray(rgba).save(tmp_path / "map.png")
    # trinary, means of four channels: 63.75 occupied, 254.25 free, red 127.5 and yellow 191.25 unknown,
    # transparent black 0 occupied, map_saver's grey 217.5 free (as map_server reads it), half-opaque 32 occupied
    trinary = load_map(write_yaml(tmp_path, "map.png")).data
    assert trinary.tolist() == [[100, 0, -1, -1, 100, 0, 100]]
    # scale, means of the colours: red 85 occupied, yellow 170 -> rint(100 * (0.333 - 0.196) / 0.454) = 30,
    # grey 205 a hair above free_thresh -> 0; anything not fully opaque unknown
    scale = load_map(write_yaml(tmp_path, "map.png", mode="scale")).data
    assert scale.tolist() == [[100, 0, 100, 30, -1, 0, -1]]


@pytest.mark.parametrize("mode", ["L", "P", "LA", "I;16"])
def test_png_modes_read_as_the_pgm(tmp_path, mode):
    grey = np.array([[0, 89, 90, 205], [206, 255, 153, 30]], dtype=np.uint8)
    expected = load_pixels(tmp_path, grey, mode="scale")
    image = Image.fromarray(grey)
    if mode == "LA":
        image = Image.fromarray(np.stack([grey, np.full_like(grey, 255)], axis=2))
    elif mode == "I;16":
        image = Image.fromarray(grey.astype(np.uint16) * 257)
    elif mode == "P":
        image = image.convert("P")
    image.save(tmp_path / "map.png")
    assert np.array_equal(load_map(write_yaml(tmp_path, "map.png", mode="scale")).data[::-1], expected)


# -- writing -------------------------------------------------------------------------------------
@pytest.mark.parametrize("mode, values", [("trinary", [-1, 0, 100]), ("scale", range(-1, 101)),
                                          ("raw", range(-1, 101))])
def test_save_then_load_gives_the_same_map(tmp_path, mode, values):
    original = random_map(np.random.default_rng(4), list(values), shape=(31, 17))
    image = save_map(original, tmp_path / "office.yaml", mode=mode)
    assert image.name == ("office.png" if mode == "scale" else "office.pgm")
    loaded = load_map(tmp_path / "office.yaml")
    assert np.array_equal(loaded.data, original.data)
    assert loaded.resolution == original.resolution and loaded.origin == original.origin


def test_trinary_save_classifies_as_map_saver(tmp_path):
    cells = np.array([[-1, 0, 25, 26, 64, 65, 100, 101]], dtype=np.int8)
    save_map(OccupancyMap(cells, 0.1), tmp_path / "m.yaml", occupied_thresh=0.65, free_thresh=0.25)
    raw = (tmp_path / "m.pgm").read_bytes()
    assert list(raw[-8:]) == [205, 254, 254, 205, 205, 0, 0, 205]
    assert load_map(tmp_path / "m.yaml").data.tolist() == [[-1, 0, 0, -1, -1, 100, 100, -1]]


def test_scale_save_with_other_thresholds_and_too_close_ones(tmp_path):
    original = random_map(np.random.default_rng(5), list(range(-1, 101)), shape=(12, 12))
    save_map(original, tmp_path / "m.yaml", mode="scale", occupied_thresh=0.9, free_thresh=0.1)
    assert np.array_equal(load_map(tmp_path / "m.yaml").data, original.data)
    with Image.open(tmp_path / "m.png") as image:
        pixels = np.asarray(image)[::-1]                                # grey and alpha, bottom row first
    cells = original.data
    assert np.all(pixels[cells == 0, 0] == 255) and np.all(pixels[cells == 100, 0] == 0)
    assert np.all(pixels[cells == -1, 1] == 0) and np.all(pixels[cells != -1, 1] == 255)
    with pytest.raises(MapError, match="leave no grey level for the value"):
        scale_greys(0.6, 0.5)


@pytest.mark.parametrize("kwargs, message", [
    ({"mode": "fancy"}, "m.yaml: mode: expected trinary"),
    ({"occupied_thresh": 1.2}, "m.yaml: occupied_thresh: must be in"),
    ({"free_thresh": 0.7}, "m.yaml: free_thresh: 0.7 must be below occupied_thresh 0.65"),
])
def test_save_refuses_bad_arguments(tmp_path, kwargs, message):
    with pytest.raises(MapError, match=message):
        save_map(OccupancyMap(np.zeros((2, 2), np.int8), 0.1), tmp_path / "m.yaml", **kwargs)
    assert not (tmp_path / "m.yaml").exists()


# -- bad input -----------------------------------------------------------------------------------
def assert_one_line(err, *parts):
    text = str(err.value)
    assert "\n" not in text and all(part in text for part in parts), text


@pytest.mark.parametrize("yaml_text, key", [
    ("image: none.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "image: no such file"),
    ("image: map.pgm\norigin: [0, 0, 0]\n", "resolution: missing"),
    ("image: map.pgm\nresolution: -0.05\norigin: [0, 0, 0]\n", "resolution: must be positive"),
    ("image: map.pgm\nresolution: 0\norigin: [0, 0, 0]\n", "resolution: must be positive"),
    ("image: map.pgm\nresolution: .nan\norigin: [0, 0, 0]\n", "resolution: expected a finite number"),
    ("image: map.pgm\nresolution: fine\norigin: [0, 0, 0]\n", "resolution: expected a finite number"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nmode: fancy\n", "mode: expected trinary, scale or raw"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0]\n", "origin: expected [x, y, yaw]"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, x]\n", "origin: expected a finite number"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 1.5\n", "occupied_thresh: must be in"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: -0.1\n", "free_thresh: must be in"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.7\n", "free_thresh: 0.7 must be below"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 2\n", "negate: expected 0 or 1"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nocupied_thresh: 0.6\n",
     "ocupied_thresh: unknown key (did you mean 'occupied_thresh'?)"),
    ("image: [map.pgm]\nresolution: 0.05\norigin: [0, 0, 0]\n", "image: expected a file name"),
    ("- just a list\n", "expected a mapping"),
    ("image: map.pgm\nresolution: [0.05\n", "not valid YAML"),
])
def test_bad_yaml_is_one_line_naming_file_and_key(tmp_path, yaml_text, key):
    write_pgm(tmp_path / "map.pgm", np.zeros((2, 2), np.uint8))
    (tmp_path / "map.yaml").write_text(yaml_text)
    with pytest.raises(MapError) as err:
        load_map(tmp_path / "map.yaml")
    assert_one_line(err, "map.yaml", key)


def test_a_missing_yaml_file(tmp_path):
    with pytest.raises(MapError) as err:
        load_map(tmp_path / "nothere.yaml")
    assert_one_line(err, "nothere.yaml: no such file")


@pytest.mark.parametrize("content, problem", [
    (b"P5\n20 20\n255\n" + bytes(10), "PGM has fewer than 20 x 20 pixels"),
    (b"P2\n3 3\n255\n1 2 3 4\n", "PGM has fewer than 9 pixels"),
    (b"P5\n20", "truncated PGM header"),
    (b"", "truncated PGM header"),
    (b"P6\n2 2\n255\n" + bytes(12), "not a greyscale PGM (magic b'P6'"),
    (b"\x89PNG\r\n\x1a\n" + bytes(40), "not a greyscale PGM"),
    (b"P5\nabc 2\n255\n" + bytes(8), "garbage PGM header: width b'abc' is not a whole number"),
    (b"P5\n2 2\n0\n" + bytes(4), "maxval 0 not in 1..65535"),
    (b"P5\n2 2\n70000\n" + bytes(8), "maxval 70000 not in 1..65535"),
    (b"P5\n0 2\n255\n", "image is 0 x 2 pixels"),
    (b"P2\n2 2\n255\n1 2 three 4\n", "P2 pixels must be decimal numbers"),
    (b"P2\n2 2\n255\n1 2 300 4\n", "pixel value 300 above maxval 255"),
    (b"P5\n2 1\n100\n\x05\xff", "pixel value 255 above maxval 100"),
])
def test_bad_pgm_is_one_line_naming_the_yaml_its_image_key_and_the_image(tmp_path, content, problem):
    (tmp_path / "map.pgm").write_bytes(content)
    with pytest.raises(MapError) as err:
        load_map(write_yaml(tmp_path, "map.pgm"))
    assert_one_line(err, f"map.yaml: image: {tmp_path / 'map.pgm'}: ", problem)


def test_an_image_that_cannot_be_read_is_one_line(tmp_path, monkeypatch):
    write_pgm(tmp_path / "map.pgm", np.zeros((2, 2), np.uint8))

    def denied(*_args, **_kwargs):   # what a file without read permission gives (the tests run as root)
        raise PermissionError(13, "Permission denied")
    monkeypatch.setattr(images, "open", denied, raising=False)
    with pytest.raises(MapError) as err:
        load_map(write_yaml(tmp_path, "map.pgm"))
    assert_one_line(err, f"map.yaml: image: {tmp_path / 'map.pgm'}: cannot be read (Permission denied)")


def png_header_only(width, height):
    """A PNG that claims a size and holds no pixels: signature, IHDR, IEND."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)) \
        + chunk(b"IEND", b"")


@pytest.mark.parametrize("name, content, problem", [
    ("map.pgm", b"P5\n50000 50000\n255\n" + bytes(100), "image is 50000 x 50000 pixels"),
    ("map.pgm", b"P5\n16385 1\n255\n" + bytes(16385), "image is 16385 x 1 pixels"),
    ("map.pgm", b"P5\n12000 9000\n255\n", "image is 12000 x 9000 pixels"),
    ("map.png", png_header_only(50000, 50000), f"more than {MAX_CELLS} pixels"),
    ("map.png", png_header_only(MAX_SIDE + 1, 2), f"image is {MAX_SIDE + 1} x 2 pixels"),
])
def test_an_oversized_image_is_refused_from_its_header(tmp_path, name, content, problem):
    (tmp_path / name).write_bytes(content)
    path = write_yaml(tmp_path, name)
    tracemalloc.start()
    try:
        with pytest.raises(MapError) as err:
            load_map(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert_one_line(err, f"map.yaml: image: {tmp_path / name}: ", problem)
    assert peak < 2_000_000, f"{peak} bytes allocated before the refusal"


def test_garbage_and_truncated_png(tmp_path):
    (tmp_path / "map.png").write_bytes(b"not a png at all")
    with pytest.raises(MapError) as err:
        load_map(write_yaml(tmp_path, "map.png"))
    assert_one_line(err, "map.png", "not an image Pillow can read")
    Image.fromarray(np.random.default_rng(0).integers(0, 255, (64, 64), dtype=np.uint8)).save(tmp_path / "map.png")
    (tmp_path / "map.png").write_bytes((tmp_path / "map.png").read_bytes()[:300])
    with pytest.raises(MapError) as err:
        load_map(write_yaml(tmp_path, "map.png"))
    assert_one_line(err, "map.png", "cannot be decoded")


def test_occupancy_map_wants_int8_cells():
    with pytest.raises(ValueError, match="2-D int8"):
        OccupancyMap(np.zeros((2, 2)), 0.05)
