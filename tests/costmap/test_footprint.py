"""Footprint parsing, padding, radii (docs/reference.md §2.2) and footprint costs."""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.footprint import (footprint_costs, footprint_from_radius, footprint_radii,
                                                    line_cells, pad_footprint, parse_footprint, transform_footprint)

LAB = [[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]
LAB_PADDED_FOOTPRINT = pad_footprint(LAB, 0.03)


def test_string_and_list_forms_agree():
    np.testing.assert_array_equal(parse_footprint("[[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]"),
                                  parse_footprint(LAB))
    assert parse_footprint("[]").shape == (0, 2)


@pytest.mark.parametrize("bad, message", [
    ("[[1, 2], [3, 4]]", "at least three"),
    ("[[1, 2], [3], [4, 5]]", "point 1"),
    ("[[1, 2], [3, 'a'], [4, 5]]", "point 1"),
    ("[[1, 2], [3, 4], [4, 5", "cannot parse"),
    (42, "list of"),
])
def test_malformed_footprints_fail_clearly(bad, message):
    with pytest.raises(ValueError, match=message):
        parse_footprint(bad, "local_costmap/footprint")


def test_padding_is_per_axis_with_sign0():
    padded = pad_footprint([[0.45, 0.3], [0.0, -0.3], [-0.45, 0.0]], 0.03)
    np.testing.assert_allclose(padded, [[0.48, 0.33], [0.0, -0.33], [-0.48, 0.0]])


def test_lab_radii():
    inscribed, circumscribed = footprint_radii(pad_footprint(LAB, 0.03))
    assert inscribed == pytest.approx(0.33)
    assert circumscribed == pytest.approx(math.hypot(0.48, 0.33))


def test_default_round_robot_radii():
    fp = footprint_from_radius(0.46)
    assert len(fp) == 16 and np.allclose(np.hypot(fp[:, 0], fp[:, 1]), 0.46)
    inscribed, circumscribed = footprint_radii(pad_footprint(fp, 0.01))
    assert round(inscribed, 3) == 0.461 and round(circumscribed, 3) == 0.474


def test_fewer_than_three_points_keep_the_radii_costmap_2d_starts_with():
    assert footprint_radii(np.empty((0, 2))) == (math.inf, 0.0)
    assert footprint_radii([[0.1, 0.0], [0.0, 0.2]]) == (math.inf, 0.0)


def test_transform_to_pose():
    placed = transform_footprint(LAB, 1.0, 2.0, math.pi / 2)
    np.testing.assert_allclose(placed[0], [0.7, 2.45])


def reference_line(x0, y0, x1, y1):
    """costmap_2d's LineIterator, step by step."""
    dx, dy = abs(x1 - x0), abs(y1 - y0)
    xinc = 1 if x1 >= x0 else -1
    yinc = 1 if y1 >= y0 else -1
    if dx >= dy:
        xinc1, yinc1, xinc2, yinc2, den, num, numadd, numpixels = 0, yinc, xinc, 0, dx, dx // 2, dy, dx
    else:
        xinc1, yinc1, xinc2, yinc2, den, num, numadd, numpixels = xinc, 0, 0, yinc, dy, dy // 2, dx, dy
    x, y, out = x0, y0, []
    for _ in range(numpixels + 1):
        out.append((x, y))
        num += numadd
        if num >= den:
            num -= den
            x += xinc1
            y += yinc1
        x += xinc2
        y += yinc2
    return out


def test_vectorised_line_cells_match_the_line_iterator():
    rng = np.random.default_rng(0)
    ends = rng.integers(0, 40, (200, 4))
    line, mx, my = line_cells(*ends.T)
    for k, (x0, y0, x1, y1) in enumerate(ends):
        sel = line == k
        assert list(zip(mx[sel], my[sel])) == reference_line(x0, y0, x1, y1)


def empty_map():
    return Costmap2D(100, 100, 0.05, -2.5, -2.5)


def test_footprint_cost_codes():
    cm = empty_map()
    cm.costmap[:, 60] = LETHAL_OBSTACLE                 # wall at x = 0.525
    pose_free, pose_hit = np.array([0.0, 0.0, 0.0]), np.array([0.1, 0.0, 0.0])
    costs = footprint_costs(cm, LAB_PADDED_FOOTPRINT, np.array([pose_free, pose_hit, [5.0, 0.0, 0.0],
                                                                 [2.2, 0.0, 0.0]]))
    # free, front edge (x = 0.58) on the wall, centre off the map, a vertex off the map
    np.testing.assert_array_equal(costs, [0.0, -1.0, -3.0, -3.0])


def test_a_lethal_cell_inside_the_footprint_but_not_on_its_outline_is_feasible():
    cm = empty_map()
    mx, my = cm.world_to_map(0.0, 0.0)
    cm.costmap[my, mx] = LETHAL_OBSTACLE
    assert footprint_costs(cm, LAB_PADDED_FOOTPRINT, np.zeros((1, 3)))[0] == 0.0


def test_unknown_met_first_on_the_outline_wins_over_lethal():
    cm = empty_map()
    # the first edge goes from the front-left vertex (0.48, 0.33) to the front-right one
    mx, my = cm.world_to_map(0.48, 0.33)
    cm.costmap[my, mx] = NO_INFORMATION
    cm.costmap[:, cm.world_to_map(-0.48, 0.0)[0]] = LETHAL_OBSTACLE
    assert footprint_costs(cm, LAB_PADDED_FOOTPRINT, np.zeros((1, 3)))[0] == -2.0


def test_short_footprints_check_the_centre_cell_only():
    cm = empty_map()
    mx, my = cm.world_to_map(0.0, 0.0)
    cm.costmap[my, mx] = 253
    assert footprint_costs(cm, np.array([[0.1, 0.0]]), np.zeros((1, 3)))[0] == -1.0
