import math

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.teb.feasibility import (footprint_costs, footprint_inscribed_radius,
                                                  is_trajectory_feasible, line_cells)

from .scenes import LAB_PADDED_FOOTPRINT


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


def wall_map(x_wall: float):
    cm = empty_map()
    cm.costmap[:, cm.world_to_map(x_wall, 0.0)[0]] = LETHAL_OBSTACLE
    return cm


def straight_band(length: float, n: int):
    return np.column_stack([np.linspace(0, length, n + 1), np.zeros(n + 1), np.zeros(n + 1)])


def test_wall_across_the_path_is_infeasible():
    inscribed = footprint_inscribed_radius(LAB_PADDED_FOOTPRINT)
    assert inscribed == pytest.approx(0.33)
    band = straight_band(2.0, 10)                        # poses every 0.2 m
    args = dict(no_poses=5, lookahead_distance=-1.0, min_angular_resolution=math.pi)
    assert not is_trajectory_feasible(wall_map(1.2), LAB_PADDED_FOOTPRINT, inscribed, band, **args)
    # the same wall beyond pose 5 (x = 1.0 + 0.48 front) is not checked
    assert is_trajectory_feasible(wall_map(1.6), LAB_PADDED_FOOTPRINT, inscribed, band, **args)
    # a lookahead distance shorter than the wall stops the check earlier
    assert is_trajectory_feasible(wall_map(1.2), LAB_PADDED_FOOTPRINT, inscribed, band,
                                  no_poses=5, lookahead_distance=0.5, min_angular_resolution=math.pi)


def test_intermediate_poses_are_interpolated_between_distant_poses():
    inscribed = footprint_inscribed_radius(LAB_PADDED_FOOTPRINT)
    # two poses 2 m apart; the wall at x = 1.0 touches neither footprint, only the swept path
    band = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    cm = wall_map(1.0)
    assert footprint_costs(cm, LAB_PADDED_FOOTPRINT, band).tolist() == [0.0, 0.0]
    assert not is_trajectory_feasible(cm, LAB_PADDED_FOOTPRINT, inscribed, band, 5, -1.0, math.pi)
