"""InflationLayer: exact costs, brushfire equivalence, vanished halos, reinflation (docs/reference.md §2.6)."""

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.inflation_layer import InflationLayer, _brushfire, inflation_cost
from simplebot_navigation.costmap.layer import CostmapLayer
from simplebot_navigation.costmap.layered_costmap import LayeredCostmap

from simplebot_navigation.testing.costmap_reference import brushfire


class GridLayer(CostmapLayer):
    """Test layer: its own grid overwrites the master over the whole map every cycle."""

    def update_bounds(self, robot_x, robot_y, robot_yaw, bounds):
        bounds.touch(self.origin_x, self.origin_y)
        bounds.touch(self.origin_x + self.size_x * self.resolution, self.origin_y + self.size_y * self.resolution)

    def update_costs(self, master, x0, y0, xn, yn):
        self.update_with_true_overwrite(master, x0, y0, xn, yn)


def square(half):
    return [[half, half], [half, -half], [-half, -half], [-half, half]]


def make(size, res, inscribed_half, radius, weight, inflate_unknown=False):
    lc = LayeredCostmap(size_x=size, size_y=size, resolution=res)
    grid = GridLayer("grid")
    lc.add_plugin(grid)
    inflation = InflationLayer("inflation_layer", radius, weight, inflate_unknown)
    lc.add_plugin(inflation)
    lc.set_footprint(square(inscribed_half))
    return lc, grid, inflation


@pytest.mark.parametrize("r_ins, w, r_inf, table, inscribed_cells", [
    (0.325, 10.0, 0.55, {0.35: 196, 0.40: 119, 0.45: 72, 0.50: 43, 0.55: 26}, 6),
    (0.20, 3.0, 0.70, {0.25: 216, 0.30: 186, 0.40: 138, 0.50: 102, 0.70: 56}, 4),
])
def test_reference_cost_tables(r_ins, w, r_inf, table, inscribed_cells):
    lc, grid, _ = make(41, 0.05, r_ins, r_inf, w)
    assert lc.inscribed_radius == pytest.approx(r_ins)
    grid.set_cost(20, 20, LETHAL_OBSTACLE)
    lc.update_map(0, 0, 0)
    for metres, cost in table.items():
        cells = round(metres / 0.05)
        assert inflation_cost(cells, 0.05, lc.inscribed_radius, w) == cost
        for dx, dy in ((cells, 0), (-cells, 0), (0, cells), (0, -cells)):
            assert lc.costmap.get_cost(20 + dx, 20 + dy) == cost, (metres, dx, dy)
    assert lc.costmap.get_cost(20, 20) == LETHAL_OBSTACLE
    assert lc.costmap.get_cost(20 + inscribed_cells, 20) == 253
    # only cells with d <= ceil(r_inf / res) are touched
    cr = int(np.ceil(r_inf / 0.05))
    assert lc.costmap.get_cost(20 + cr + 1, 20) == 0 and lc.costmap.get_cost(20 + cr, 20) > 0


@pytest.mark.parametrize("seed, inflate_unknown", [(0, False), (1, True), (2, False)])
def test_matches_brushfire_reference_cell_for_cell(seed, inflate_unknown):
    rng = np.random.default_rng(seed)
    size, res = 60, 0.05
    lc, grid, _ = make(size, res, 0.17, 0.5, 4.0, inflate_unknown)
    costs = np.zeros((size, size), np.uint8)
    costs[rng.random((size, size)) < 0.01] = LETHAL_OBSTACLE
    costs[20:28, 30:50] = NO_INFORMATION
    costs[rng.random((size, size)) < 0.05] = rng.integers(1, 200)
    grid.costmap[:] = costs
    lc.update_map(0, 0, 0)
    expected = [list(row) for row in costs]
    brushfire(expected, size, size, 0, 0, size, size, res, lc.inscribed_radius, 4.0, 0.5, inflate_unknown)
    np.testing.assert_array_equal(lc.costmap.costmap, np.array(expected, np.uint8))


def test_unknown_cells_stay_unknown_unless_inscribed():
    lc, grid, _ = make(30, 0.05, 0.1, 0.5, 10.0)
    grid.costmap[:] = NO_INFORMATION
    grid.set_cost(15, 15, LETHAL_OBSTACLE)
    lc.update_map(0, 0, 0)
    assert lc.costmap.get_cost(17, 15) == 253            # 0.10 m: inscribed, written over unknown
    assert lc.costmap.get_cost(18, 15) == NO_INFORMATION


def test_inflate_unknown_writes_graded_costs_over_unknown():
    lc, grid, _ = make(30, 0.05, 0.1, 0.5, 10.0, inflate_unknown=True)
    grid.costmap[:] = NO_INFORMATION
    grid.set_cost(15, 15, LETHAL_OBSTACLE)
    lc.update_map(0, 0, 0)
    assert lc.costmap.get_cost(18, 15) == inflation_cost(3, 0.05, lc.inscribed_radius, 10.0)


def test_halo_of_vanished_obstacle_is_cleared():
    """The layer that lost its obstacle reports bounds elsewhere; the previous cycle's bounds still
    bring the old halo into the update window."""
    class PointLayer(CostmapLayer):
        cell = (40, 40)

        def update_bounds(self, robot_x, robot_y, robot_yaw, bounds):
            bounds.touch(*self.map_to_world(*(self.cell or (80, 80))))

        def update_costs(self, master, x0, y0, xn, yn):
            self.reset_maps()
            if self.cell:
                self.set_cost(*self.cell, LETHAL_OBSTACLE)
            self.update_with_max(master, x0, y0, xn, yn)

    lc = LayeredCostmap(size_x=100, size_y=100, resolution=0.05)
    points = PointLayer("points")
    lc.add_plugin(points)
    lc.add_plugin(InflationLayer("inflation_layer", 0.5, 10.0))
    lc.set_footprint(square(0.1))
    lc.update_map(0, 0, 0)
    lc.update_map(0, 0, 0)
    assert lc.update_window == (30, 30, 51, 51)
    assert lc.costmap.get_cost(44, 40) == inflation_cost(4, 0.05, lc.inscribed_radius, 10.0)
    points.cell = None
    lc.update_map(0, 0, 0)
    assert not lc.costmap.costmap.any()


def test_footprint_and_parameter_changes_reinflate_the_whole_map():
    class Quiet(CostmapLayer):
        def update_bounds(self, robot_x, robot_y, robot_yaw, bounds):
            bounds.touch(5.0, 5.0)

    lc = LayeredCostmap(size_x=100, size_y=100, resolution=0.1)
    lc.add_plugin(Quiet("quiet"))
    inflation = InflationLayer("inflation_layer", 0.5, 10.0)
    lc.add_plugin(inflation)
    lc.set_footprint(square(0.2))
    lc.update_map(0, 0, 0)
    lc.update_map(0, 0, 0)
    assert lc.update_window != (0, 0, 100, 100)
    lc.set_footprint(square(0.3))
    lc.update_map(0, 0, 0)
    assert lc.update_window == (0, 0, 100, 100)
    lc.update_map(0, 0, 0)
    inflation.set_inflation_parameters(0.8, 10.0)
    lc.update_map(0, 0, 0)
    assert lc.update_window == (0, 0, 100, 100)


def test_small_window_reaches_beyond_itself_like_the_brushfire():
    """Seeds come from the window grown by the inflation radius; their halos spread past it."""
    rng = np.random.default_rng(5)
    size, res = 120, 0.05
    lc, grid, inflation = make(size, res, 0.1, 1.5, 3.0)
    costs = np.where(rng.random((size, size)) < 0.02, LETHAL_OBSTACLE, 0).astype(np.uint8)
    lc.costmap.costmap[:] = costs
    inflation.update_costs(lc.costmap, 60, 60, 61, 61)
    expected = [list(row) for row in costs]
    brushfire(expected, size, size, 60, 60, 61, 61, res, lc.inscribed_radius, 3.0, 1.5)
    np.testing.assert_array_equal(lc.costmap.costmap, np.array(expected, np.uint8))
    cr = 30
    outside = np.ones((size, size), bool)
    outside[60 - cr:61 + cr, 60 - cr:61 + cr] = False
    assert (lc.costmap.costmap != costs)[outside].any()


def test_queue_overflow_then_rerun_gives_the_same_costs():
    """A run that runs out of queue space stops early; running again with more room is exact."""
    rng = np.random.default_rng(7)
    size, res = 50, 0.05
    lc, grid, inflation = make(size, res, 0.1, 0.6, 3.0, inflate_unknown=False)
    costs = np.where(rng.random((size, size)) < 0.03, LETHAL_OBSTACLE, 0).astype(np.uint8)
    costs[10:20, 10:40] = NO_INFORMATION
    lc.costmap.costmap[:] = costs
    bin_of, cost, n_bins = inflation._tables
    args = (lc.costmap.costmap, 0, 0, size, size, inflation.cell_inflation_radius, bin_of, cost, n_bins, False)
    assert _brushfire(*args, 200) == -1
    assert _brushfire(*args, 100000) > 200
    expected = [list(row) for row in costs]
    brushfire(expected, size, size, 0, 0, size, size, res, lc.inscribed_radius, 3.0, 0.6)
    np.testing.assert_array_equal(lc.costmap.costmap, np.array(expected, np.uint8))
