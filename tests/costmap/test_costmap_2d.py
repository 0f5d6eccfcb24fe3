"""Costmap2D grid operations: rolling origin, raytrace, polygon fill, translation table (docs/reference.md §0.2, §2.1)."""

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE, NO_INFORMATION, OCCUPANCY_GRID_TABLE
from simplebot_navigation.costmap.costmap_2d import Costmap2D

from simplebot_navigation.testing.costmap_reference import bresenham


def test_translation_table_samples():
    samples = {0: 0, 1: 1, 2: 1, 50: 19, 100: 39, 128: 50, 200: 77, 251: 97, 252: 98, 253: 99, 254: 100, 255: -1}
    for cost, value in samples.items():
        assert OCCUPANCY_GRID_TABLE[cost] == value


def test_update_origin_keeps_overlap_and_resets_the_rest():
    cm = Costmap2D(10, 8, 0.5, 0.0, 0.0, NO_INFORMATION)
    cm.costmap[:, :] = np.arange(80, dtype=np.uint8).reshape(8, 10)
    cm.update_origin(1.6, -0.9)           # 3.2 cells -> 3, -1.8 cells -> -1 (truncated toward zero)
    assert (cm.origin_x, cm.origin_y) == (1.5, -0.5)
    expected = np.full((8, 10), NO_INFORMATION, np.uint8)
    expected[1:, :7] = np.arange(80, dtype=np.uint8).reshape(8, 10)[:7, 3:]
    np.testing.assert_array_equal(cm.costmap, expected)


def test_update_origin_smaller_than_a_cell_does_nothing():
    cm = Costmap2D(4, 4, 0.1, 1.0, 1.0)
    cm.set_cost(2, 2, LETHAL_OBSTACLE)
    cm.update_origin(1.099, 0.901)
    assert (cm.origin_x, cm.origin_y) == (1.0, 1.0) and cm.get_cost(2, 2) == LETHAL_OBSTACLE


def test_update_origin_beyond_the_map_clears_everything():
    cm = Costmap2D(4, 4, 1.0, 0.0, 0.0, 0)
    cm.costmap[:] = LETHAL_OBSTACLE
    cm.update_origin(10.0, 0.0)
    assert cm.origin_x == 10.0 and not cm.costmap.any()


def test_raytrace_includes_start_and_final_cell():
    cm = Costmap2D(20, 20, 0.1, 0.0, 0.0)
    assert cm.raytrace_line(0, 0, 5, 2) == [(0, 0), (1, 0), (2, 1), (3, 1), (4, 2), (5, 2)]
    assert cm.raytrace_line(3, 3, 3, 3) == [(3, 3)]
    # max length 3 cells along a 10-cell ray: three steps, then the cell it stopped on
    assert cm.raytrace_line(10, 10, 0, 7, 3) == [(10, 10), (9, 10), (8, 9)]


def test_raytrace_matches_bresenham_loop_for_many_rays():
    cm = Costmap2D(30, 30, 0.1, 0.0, 0.0)
    rng = np.random.default_rng(1)
    ends = rng.integers(0, 30, (500, 2))
    starts = rng.integers(0, 30, (500, 2))
    lengths = rng.integers(0, 40, 500)
    for (x0, y0), (x1, y1), max_len in zip(starts, ends, lengths):
        assert cm.raytrace_line(x0, y0, x1, y1, max_len) == bresenham(x0, y0, x1, y1, max_len)
    # vectorised: several rays in one call, concatenated in order
    mx, my = cm.raytrace_cells(5, 5, ends[:20, 0], ends[:20, 1], 12)
    expected = [c for x1, y1 in ends[:20] for c in bresenham(5, 5, x1, y1, 12)]
    assert list(zip(mx.tolist(), my.tolist())) == expected


def test_convex_polygon_fill():
    cm = Costmap2D(10, 10, 1.0, 0.0, 0.0)
    assert cm.set_convex_polygon_cost([(2.5, 2.5), (6.5, 2.5), (6.5, 4.5), (2.5, 4.5)], LETHAL_OBSTACLE)
    expected = np.zeros((10, 10), np.uint8)
    expected[2:5, 2:7] = LETHAL_OBSTACLE
    np.testing.assert_array_equal(cm.costmap, expected)
    cm.reset_maps()
    assert cm.set_convex_polygon_cost([(1.2, 1.2), (8.7, 1.5), (4.1, 8.9)], 7)
    assert cm.get_cost(4, 4) == 7 and cm.get_cost(1, 8) == 0 and cm.get_cost(8, 1) == 7


def test_convex_polygon_fill_fails_whole_if_a_vertex_is_off_the_map():
    cm = Costmap2D(10, 10, 1.0, 0.0, 0.0)
    assert not cm.set_convex_polygon_cost([(2.5, 2.5), (12.0, 2.5), (6.5, 4.5)], LETHAL_OBSTACLE)
    assert not cm.costmap.any()


@pytest.mark.parametrize("wx, expected", [(-0.01, None), (0.0, (0, 0)), (0.999, (9, 0)), (1.0, None), (1e308, None),
                                         (-1e308, None), (float("inf"), None), (float("nan"), None)])
def test_world_to_map_bounds(wx, expected):
    assert Costmap2D(10, 10, 0.1, 0.0, 0.0).world_to_map(wx, 0.0) == expected


def test_window_copy_is_row_major():
    cm = Costmap2D(4, 3, 1.0, 0.0, 0.0)
    cm.costmap[:] = np.arange(12).reshape(3, 4)
    np.testing.assert_array_equal(cm.window(1, 1, 3, 3).ravel(), [5, 6, 9, 10])
