"""The log-odds grid maps a synthetic room as a user would draw it, grows without moving what it holds, renders
the same map from scratch, and refuses what it cannot hold or read."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import binary_dilation

from simplebot_navigation.geometry import compose2
from simplebot_navigation.slam.occupancy import LogOddsGrid, render
from simplebot_navigation.slam.scan_points import scan_points

RESOLUTION = 0.05
#: the room: a 6 m x 5 m box of walls, and a 1 m x 1 m crate in it; segments (x0, y0, x1, y1)
ROOM = np.array([[0, 0, 6, 0], [6, 0, 6, 5], [6, 5, 0, 5], [0, 5, 0, 0]], dtype=float)
CRATE = np.array([[3.5, 1.5, 4.5, 1.5], [4.5, 1.5, 4.5, 2.5], [4.5, 2.5, 3.5, 2.5], [3.5, 2.5, 3.5, 1.5]])
WALLS = np.concatenate([ROOM, CRATE])
#: where the robot scans from: a lap around the crate, so that every wall is seen and every cell inside is
#: crossed by the four scans that make it free (0.4 log-odds each against free_threshold's 1.41)
POSES = np.array([(1.0, 1.0, 0.3), (2.5, 0.8, 1.0), (5.2, 0.8, 2.5), (5.3, 2.0, 1.6), (5.2, 4.2, 2.0),
                  (3.0, 3.8, 0.0), (1.5, 3.8, -1.0), (1.2, 2.4, 0.0), (3.2, 1.2, -0.5), (4.8, 3.2, 3.0)])
#: the lidar on the base: two 683-beam lidars' worth of beams over a full turn, 5.6 m of range
SENSOR, BEAMS, RANGE_MAX = (0.1, 0.0, 0.0), 1366, 5.6


def cast(origin, angles) -> np.ndarray:
    """Ranges from ``origin`` along ``angles`` to the nearest wall (inf where none is met): the room's truth."""
    d = np.column_stack((np.cos(angles), np.sin(angles)))[:, None, :]                # (B, 1, 2)
    a, e = WALLS[None, :, :2], (WALLS[:, 2:] - WALLS[:, :2])[None]                   # (1, S, 2)
    w = a - np.asarray(origin)[None, None, :]
    denom = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / denom
        u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / denom
    valid = (np.abs(denom) > 1e-12) & (t > 1e-9) & (u >= 0) & (u <= 1)
    return np.where(valid, t, np.inf).min(axis=1)


def room_scan(pose):
    """The scan the lidar takes at ``pose`` in the room, as SLAM keeps it (base frame)."""
    increment = 2 * math.pi / BEAMS
    sensor = compose2(tuple(pose), SENSOR)
    angles = sensor[2] - math.pi + increment * np.arange(BEAMS)
    ranges = cast(sensor[:2], angles)
    ranges[ranges > RANGE_MAX] = np.inf
    return scan_points(ranges, -math.pi, increment, 0.1, RANGE_MAX, SENSOR, RANGE_MAX)


def integrated(poses, **kwargs) -> tuple[LogOddsGrid, list]:
    grid, scans = LogOddsGrid(RESOLUTION, **kwargs), [room_scan(p) for p in poses]
    for pose, scan in zip(poses, scans):
        grid.integrate(*scan.in_frame(pose), scan.hits)
    return grid, scans


def cell_centres(grid: LogOddsGrid) -> tuple[np.ndarray, np.ndarray]:
    rows, cols = grid.shape
    return (grid.origin[0] + (np.arange(cols) + 0.5) * grid.resolution)[None, :], \
        (grid.origin[1] + (np.arange(rows) + 0.5) * grid.resolution)[:, None]


def true_wall_cells(grid: LogOddsGrid) -> np.ndarray:
    """(rows, cols) bool: the cells the wall segments pass through."""
    mask = np.zeros(grid.shape, dtype=bool)
    for x0, y0, x1, y1 in WALLS:
        s = np.linspace(0.0, 1.0, int(math.hypot(x1 - x0, y1 - y0) / grid.resolution * 8) + 2)[:, None]
        cells = grid.cells_of(np.column_stack((x0 + s * (x1 - x0), y0 + s * (y1 - y0))))
        mask[cells[:, 1], cells[:, 0]] = True
    return mask


def value_at(grid: LogOddsGrid, points) -> np.ndarray:
    cells = grid.cells_of(points)
    return grid.log_odds[cells[:, 1], cells[:, 0]]


def test_the_room_is_mapped():
    grid, _ = integrated(POSES)
    data = grid.occupancy_map().data
    occupied, walls = data == 100, true_wall_cells(grid)
    one_cell = np.ones((3, 3), dtype=bool)
    # Within one cell: a return on a wall lying on a cell boundary may land on either side of it.
    precision = (occupied & binary_dilation(walls, one_cell)).sum() / occupied.sum()
    recall = (walls & binary_dilation(occupied, one_cell)).sum() / walls.sum()
    assert precision >= 0.95 and recall >= 0.95, (precision, recall)
    x, y = cell_centres(grid)
    margin = 2 * RESOLUTION         # two cells clear of every wall
    in_room = (x > margin) & (x < 6 - margin) & (y > margin) & (y < 5 - margin)
    in_crate = (x > 3.5 - margin) & (x < 4.5 + margin) & (y > 1.5 - margin) & (y < 2.5 + margin)
    inside = in_room & ~in_crate
    assert (data[inside] == 0).mean() >= 0.99     # 1 % spare for a corner crossed by fewer scans
    assert not occupied[inside].any()
    outside = (x < -margin) | (x > 6 + margin) | (y < -margin) | (y > 5 + margin)
    within_crate = (x > 3.5 + margin) & (x < 4.5 - margin) & (y > 1.5 + margin) & (y < 2.5 - margin)
    assert outside.any() and (data[outside] == -1).all()
    assert (data[within_crate] == -1).all()


def test_a_miss_beam_clears_and_marks_nothing():
    grid = LogOddsGrid(RESOLUTION)
    grid.integrate([[0.02, 0.02]], [[1.02, 0.32]], np.array([False]))
    assert (grid.log_odds > 0).sum() == 0
    assert (grid.log_odds < 0).sum() == 21          # Bresenham over 20 columns: 21 cells, the end one too
    assert value_at(grid, [[1.02, 0.32]])[0] < 0
    assert (grid.occupancy_map().data != 100).all()


def test_a_return_marks_its_end_cell_and_clears_the_way():
    grid = LogOddsGrid(RESOLUTION, hit_probability=0.7, miss_probability=0.4)
    grid.integrate([[0.02, 0.02]], [[1.02, 0.32]], np.array([True]))
    assert value_at(grid, [[1.02, 0.32]])[0] == pytest.approx(math.log(0.7 / 0.3), rel=1e-6)
    assert (grid.log_odds > 0).sum() == 1 and (grid.log_odds < 0).sum() == 20
    assert value_at(grid, [[0.97, 0.32]])[0] == pytest.approx(math.log(0.4 / 0.6), rel=1e-6)


def test_one_scan_updates_a_cell_once_and_keeps_its_returns():
    grid = LogOddsGrid(RESOLUTION)
    angles = np.linspace(0.0, 0.2, 50)
    ends = np.column_stack((2.0 * np.cos(angles), 2.0 * np.sin(angles)))
    grid.integrate(np.zeros((50, 2)), ends, np.ones(50, dtype=bool))
    # fifty beams leave their shared start cell once cleared, not clamped
    assert value_at(grid, [[0.0, 0.0]])[0] == pytest.approx(math.log(0.4 / 0.6), rel=1e-6)
    # and a beam ending just beyond another's return does not clear that return
    grid = LogOddsGrid(RESOLUTION)
    grid.integrate(np.zeros((2, 2)), [[1.0, 0.001], [1.5, 0.001]], np.array([True, True]))
    assert value_at(grid, [[1.0, 0.001]])[0] == pytest.approx(math.log(0.7 / 0.3), rel=1e-6)


@pytest.mark.parametrize("far", [(9.0, 0.3), (-9.0, 0.3), (0.3, 9.0), (0.3, -9.0)])
def test_growth_keeps_cells_where_they_were(far):
    grid, _ = integrated(POSES[:1])
    probes = np.array([[0.0, 1.0], [1.2, 2.0], [6.0, 2.5], [3.0, 3.0], [4.0, 1.5]])
    before, shape = value_at(grid, probes), grid.shape
    grid.integrate([np.multiply(far, 0.8)], [far], np.array([True]))
    assert grid.shape[0] > shape[0] or grid.shape[1] > shape[1]
    assert value_at(grid, [far])[0] > 0                     # the far return is in the grown part
    np.testing.assert_array_equal(value_at(grid, probes), before)   # the same cells, untouched by the beam
    for coordinate in grid.origin:          # cells stay on the world's lattice
        assert abs(coordinate / RESOLUTION - round(coordinate / RESOLUTION)) < 1e-9


def test_render_equals_incremental_integration():
    grid, scans = integrated(POSES)
    rendered = render(POSES, scans, RESOLUTION)
    assert rendered.shape == grid.shape and rendered.origin == grid.origin
    np.testing.assert_allclose(rendered.log_odds, grid.log_odds, atol=1e-5)   # the same updates in the same order
    np.testing.assert_array_equal(rendered.occupancy_map().data, grid.occupancy_map().data)
    part = render(POSES[:2], scans[:2], RESOLUTION)
    offset = (np.array(part.origin) - np.array(grid.origin)) / RESOLUTION
    np.testing.assert_allclose(offset, np.round(offset), atol=1e-9)          # the same cell lattice


def test_growth_beyond_max_cells_is_refused_and_changes_nothing():
    grid = LogOddsGrid(RESOLUTION, max_cells=2 * 40 * 40)      # two 2 m chunks
    grid.integrate([[0.1, 0.1]], [[1.0, 1.0]], np.array([True]))
    grid.integrate([[0.1, 0.1]], [[3.0, 0.5]], np.array([True]))
    assert grid.shape == (40, 80)
    before, origin = grid.log_odds.copy(), grid.origin
    with pytest.raises(ValueError, match="max_cells"):
        grid.integrate([[0.1, 0.1]], [[5.0, 5.0]], np.array([True]))
    assert grid.shape == (40, 80) and grid.origin == origin
    np.testing.assert_array_equal(grid.log_odds, before)
    with pytest.raises(ValueError, match="max_cells"):
        render(POSES[:1], [room_scan(POSES[0])], RESOLUTION, max_cells=1000)


@pytest.mark.parametrize("origins, ends, hits, name", [
    ([[np.nan, 0.0]], [[1.0, 0.0]], [True], "origins"),
    ([[0.0, 0.0]], [[np.inf, 0.0]], [True], "ends"),
    ([[0.0, 0.0]], [[1e9, 0.0]], [True], "ends"),
    ([[0.0, 0.0, 0.0]], [[1.0, 0.0]], [True], "origins"),
    ([[0.0, 0.0]], [[1.0, 0.0], [2.0, 0.0]], [True], "origins, ends, hits"),
    ([[0.0, 0.0]], [[1.0, 0.0]], [1], "origins, ends, hits"),
])
def test_hostile_beams_are_refused(origins, ends, hits, name):
    grid = LogOddsGrid(RESOLUTION)
    with pytest.raises(ValueError, match=f"^{name}"):
        grid.integrate(np.array(origins), np.array(ends), np.array(hits))
    assert grid.shape == (0, 0)


@pytest.mark.parametrize("kwargs, name", [
    ({"hit_probability": 0.5}, "hit_probability"), ({"hit_probability": 1.0}, "hit_probability"),
    ({"miss_probability": 0.5}, "miss_probability"), ({"miss_probability": math.nan}, "miss_probability"),
    ({"clamp": (0.0, 0.97)}, "clamp"), ({"clamp": (0.12, 1.0)}, "clamp"), ({"clamp": (0.6, 0.97)}, "clamp"),
    ({"resolution": 0.0}, "resolution"), ({"resolution": math.nan}, "resolution"),
    ({"max_cells": 0}, "max_cells"),
])
def test_bad_grid_parameters_are_refused(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}"):
        LogOddsGrid(**kwargs)


def test_bad_render_and_map_arguments_are_refused():
    scan = room_scan(POSES[0])
    with pytest.raises(ValueError, match="^poses"):
        render([(0.0, np.nan, 0.0)], [scan])
    with pytest.raises(ValueError, match="^scans"):
        render(POSES[:2], [scan])
    with pytest.raises(ValueError, match="^scans"):
        render(POSES[:1], ["not a scan"])
    with pytest.raises(ValueError, match=r"^scans\[0\] at poses\[0\]"):
        render([(1e9, 0.0, 0.0)], [scan])
    grid = LogOddsGrid(RESOLUTION)
    with pytest.raises(ValueError, match="^free_threshold"):
        grid.occupancy_map(occupied_threshold=0.3, free_threshold=0.4)
    with pytest.raises(ValueError, match="^occupied_threshold"):
        grid.occupancy_map(occupied_threshold=np.nan)
