"""StaticLayer from an OccupancyGrid (docs/reference.md §2.4)."""

import numpy as np
import pytest

from simplebot_navigation.costmap.layered_costmap import LayeredCostmap
from simplebot_navigation.costmap.static_layer import StaticLayer


def make(rolling=False, **kw):
    lc = LayeredCostmap(rolling, False, 10, 10, 0.05, 0.0, 0.0)
    layer = StaticLayer("static_layer", **kw)
    lc.add_plugin(layer)
    lc.set_footprint([[0.1, 0.1], [0.1, -0.1], [-0.1, -0.1]])
    return lc, layer


@pytest.mark.parametrize("kw, expected", [
    ({}, [255, 0, 0, 254, 254]),
    ({"trinary_costmap": False}, [255, 0, 127, 254, 254]),
    ({"track_unknown_space": False}, [0, 0, 0, 254, 254]),
    ({"lethal_cost_threshold": 40, "trinary_costmap": False}, [255, 0, 254, 254, 254]),
    ({"lethal_cost_threshold": 60, "trinary_costmap": False}, [255, 0, 211, 254, 254]),
])
def test_interpret_values(kw, expected):
    _, layer = make(**kw)
    assert layer.interpret_values(np.array([-1, 0, 50, 100, 120], np.int8)).tolist() == expected


def test_first_map_resizes_and_locks_the_layered_costmap():
    lc, layer = make()
    grid = np.zeros((20, 30), np.int8)
    grid[5, 7] = 100
    grid[0, :] = -1
    layer.incoming_map(grid, 0.1, -1.0, -2.0, "/map")
    assert (lc.costmap.size_x, lc.costmap.size_y, lc.costmap.resolution, lc.costmap.origin_x) == (30, 20, 0.1, -1.0)
    assert lc.size_locked and layer.map_frame == "map"
    lc.update_map(0, 0, 0)
    assert lc.update_window == (0, 0, 30, 20)
    assert lc.costmap.get_cost(7, 5) == 254 and lc.costmap.get_cost(3, 0) == 255 and lc.costmap.get_cost(3, 3) == 0
    lc.update_map(0, 0, 0)                                   # nothing new: no bounds from this layer
    assert lc.update_window == (0, 0, 30, 20)
    layer.incoming_update(2, 3, np.full((2, 2), 100, np.int8))
    lc.update_map(0, 0, 0)
    assert lc.update_window == (2, 3, 5, 6) and lc.costmap.get_cost(3, 4) == 254


def test_rolling_window_copies_through_the_map_transform():
    lc, layer = make(rolling=True)
    grid = np.zeros((100, 100), np.int8)
    grid[50, 60] = 100                                       # map cell centre at (6.05, 5.05)
    layer.incoming_map(grid, 0.1, 0.0, 0.0, "map")
    layer.global_to_map = (1.0, 0.0, 0.0)                    # map = global + (1, 0)
    lc.update_map(5.05, 5.05, 0.0)
    mx, my = lc.costmap.world_to_map(5.05, 5.05)
    assert lc.costmap.get_cost(mx, my) == 254


def test_a_run_time_change_reads_the_held_map_again_and_applies_it_in_full():
    lc, layer = make()
    grid = np.zeros((20, 30), np.int8)
    grid[5, 7], grid[6, 7] = 50, -1
    layer.incoming_map(grid, 0.1, -1.0, -2.0, "map")
    lc.update_map(0, 0, 0)
    layer.incoming_update(2, 3, np.full((1, 1), 60, np.int8))
    lc.update_map(0, 0, 0)
    assert (lc.costmap.get_cost(7, 5), lc.costmap.get_cost(2, 3), lc.costmap.get_cost(7, 6)) == (0, 0, 255)
    layer.reconfigure(first_map_only=False, track_unknown_space=False, use_maximum=False, lethal_cost_threshold=50,
                      unknown_cost_value=-1, trinary_costmap=True, enabled=True)
    lc.update_map(0, 0, 0)
    assert lc.update_window == (0, 0, 30, 20)                # the whole map, not only what changed last
    # the map cell at 50 and the updated one at 60 are lethal now; unknown became free
    assert (lc.costmap.get_cost(7, 5), lc.costmap.get_cost(2, 3), lc.costmap.get_cost(7, 6)) == (254, 254, 0)
