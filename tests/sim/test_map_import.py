"""map_server maps (map.yaml + image) as worlds: occupied pixels become boxes."""

import math

import numpy as np
import pytest

from simplebot_navigation.sim import load_world
from simplebot_navigation.sim.map_import import occupied_rectangles

RES = 0.1
ORIGIN = (-1.0, -0.5)


def grid():
    """A 12 x 20 map (rows top to bottom): a wall along the top, a block, and one grey pixel."""
    img = np.full((12, 20), 254, dtype=np.uint8)
    img[0, :] = 0           # top wall
    img[6:9, 4:7] = 0       # 3 x 3 block
    img[10, 15] = 205       # unknown (map_saver's grey): not an obstacle
    return img


def write_pgm(path, img, binary=True):
    h, w = img.shape
    if binary:
        path.write_bytes(b"P5\n# CREATOR: test\n%d %d\n255\n" % (w, h) + img.tobytes())
    else:
        path.write_text(f"P2\n{w} {h}\n255\n" + "\n".join(" ".join(map(str, row)) for row in img) + "\n")


def write_yaml(tmp_path, image, extra=""):
    path = tmp_path / "map.yaml"
    path.write_text(f"image: {image}\nresolution: {RES}\norigin: [{ORIGIN[0]}, {ORIGIN[1]}, 0.0]\n"
                    f"negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n{extra}")
    return path


def pixel_centres(img):
    h, w = img.shape
    rows, cols = np.mgrid[0:h, 0:w]
    x = ORIGIN[0] + (cols + 0.5) * RES
    y = ORIGIN[1] + (h - rows - 0.5) * RES
    return np.column_stack((x.ravel(), y.ravel()))


def occupied_mask(img):
    return ((255.0 - img) / 255.0 > 0.65).ravel()


@pytest.mark.parametrize("binary", [True, False])
def test_pgm_map_extrudes_exactly_the_occupied_pixels(tmp_path, binary):
    img = grid()
    write_pgm(tmp_path / "map.pgm", img, binary)
    world = load_world(write_yaml(tmp_path, "map.pgm", "start: {x: 0.5, y: 0.0}\n"))
    assert world.name == "map" and world.source == "map.yaml"
    dist = world.distance(pixel_centres(img))
    mask = occupied_mask(img)
    assert np.all(dist[mask] == 0.0)
    assert np.all(dist[~mask] >= RES / 2 - 1e-9)
    # Runs are merged: the wall is one box, the block one box.
    assert len(world.boxes) == 2
    wall = max(world.boxes, key=lambda b: b.size[0])
    assert wall.size == pytest.approx((2.0, 0.1))
    assert wall.center == pytest.approx((0.0, 0.65))


def test_png_map_matches_pgm(tmp_path):
    image = pytest.importorskip("PIL.Image")
    img = grid()
    write_pgm(tmp_path / "map.pgm", img)
    image.fromarray(np.stack([img] * 3, axis=2)).save(tmp_path / "map.png")
    a = load_world(write_yaml(tmp_path, "map.pgm"))
    b = load_world(write_yaml(tmp_path, "map.png"))
    assert a.boxes == b.boxes


def test_negate_inverts_the_image(tmp_path):
    img = 255 - grid()
    write_pgm(tmp_path / "map.pgm", img)
    path = write_yaml(tmp_path, "map.pgm")
    path.write_text(path.read_text().replace("negate: 0", "negate: 1"))
    world = load_world(path)
    assert np.all(world.distance(pixel_centres(img))[occupied_mask(grid())] == 0.0)


def test_origin_yaw_rotates_the_map(tmp_path):
    img = np.full((4, 4), 254, dtype=np.uint8)
    img[3, 3] = 0  # bottom-right pixel: (0.35, 0.05) from the origin before rotation
    write_pgm(tmp_path / "map.pgm", img)
    path = tmp_path / "map.yaml"
    path.write_text("image: map.pgm\nresolution: 0.1\norigin: [1.0, 2.0, 1.5707963267948966]\n"
                    "start: {x: 0.0, y: 0.0}\n")
    (box,) = load_world(path).boxes
    assert box.center == pytest.approx((1.0 - 0.05, 2.0 + 0.35))
    assert box.yaw == pytest.approx(math.pi / 2)


def test_start_on_an_occupied_pixel_is_rejected(tmp_path):
    write_pgm(tmp_path / "map.pgm", grid())
    with pytest.raises(ValueError, match=r"map.yaml: start \(0.0, 0.65\) is inside boxes\[\d\]"):
        load_world(write_yaml(tmp_path, "map.pgm", "start: {x: 0.0, y: 0.65}\n"))


@pytest.mark.parametrize("yaml_text, message", [
    ("image: map.pgm\norigin: [0, 0, 0]\n", "map.yaml: resolution: missing"),
    ("image: map.pgm\nresolution: -0.05\norigin: [0, 0, 0]\n", "map.yaml: resolution: must be positive"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0]\n", r"map.yaml: origin: expected \[x, y, yaw\]"),
    ("image: nothere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "map.yaml: image: no such file"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nmode: fancy\n", "map.yaml: mode: expected trinary"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 2\n", "map.yaml: negate: expected 0 or 1"),
    ("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\ncolour: red\n", "map.yaml: colour: unknown key"),
])
def test_bad_map_yaml(tmp_path, yaml_text, message):
    write_pgm(tmp_path / "map.pgm", grid())
    (tmp_path / "map.yaml").write_text(yaml_text)
    with pytest.raises(ValueError, match=message):
        load_world(tmp_path / "map.yaml")


def test_bad_pgm(tmp_path):
    (tmp_path / "map.pgm").write_bytes(b"P6\n2 2\n255\n" + bytes(12))
    with pytest.raises(ValueError, match=r"map.pgm: not a greyscale PGM \(magic b'P6'"):
        load_world(write_yaml(tmp_path, "map.pgm"))
    (tmp_path / "map.pgm").write_bytes(b"P5\n20 20\n255\n" + bytes(10))
    with pytest.raises(ValueError, match="map.pgm: PGM has fewer than 20 x 20 pixels"):
        load_world(write_yaml(tmp_path, "map.pgm"))


def test_rectangles_cover_the_mask_exactly():
    rng = np.random.default_rng(1)
    mask = rng.random((30, 40)) < 0.3
    cover = np.zeros_like(mask, dtype=int)
    for r0, r1, c0, c1 in occupied_rectangles(mask):
        cover[r0:r1, c0:c1] += 1
    assert np.array_equal(cover, mask.astype(int))
