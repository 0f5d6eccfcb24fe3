"""Hostile LaserScans cannot put phantom obstacles into (or NaN through) the obstacle layer."""

import logging
import math

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE
from simplebot_navigation.costmap.layered_costmap import LayeredCostmap
from simplebot_navigation.costmap.observation import (ObservationSource, laser_scan_to_observation,
                                                      point_cloud_to_observation)
from simplebot_navigation.costmap.obstacle_layer import ObstacleLayer

SENSOR = (2.5, 2.5, 0.0, 0.0)      # mid-map, looking along +x
GOOD = dict(ranges=[1.0, 1.0, 1.0], angle_min=-0.01, angle_increment=0.01, range_min=0.2, range_max=5.6,
            sensor_pose=SENSOR)
LOGGER = "simplebot_navigation.costmap.observation"


def make_costmap():
    """A 5 x 5 m costmap with one obstacle layer whose single source clears and marks."""
    lc = LayeredCostmap(False, False, 100, 100, 0.05, 0.0, 0.0, clock=lambda: 0.0, update_period=0.1)
    layer = ObstacleLayer("obstacles", [ObservationSource("scan", data_type="LaserScan", marking=True,
                                                          clearing=True, obstacle_range=15.0, raytrace_range=20.0)],
                          footprint_clearing_enabled=False)
    lc.add_plugin(layer)
    return lc, layer


def costmap_after(*scans):
    """The costmap after each scan (a dict of LaserScan fields) is added and the map updated."""
    lc, layer = make_costmap()
    for scan in scans:
        layer.add_observation("scan", laser_scan_to_observation(stamp=0.0, obstacle_range=15.0, raytrace_range=20.0,
                                                                **scan))
        lc.update_map(*SENSOR[:2], 0.0)
    return lc


def lethal_cells(lc) -> list[list[int]]:
    return np.argwhere(lc.costmap.costmap == LETHAL_OBSTACLE).tolist()


def test_negative_ranges_are_never_obstacles_behind_the_sensor(caplog):
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        lc = costmap_after(dict(GOOD, ranges=[-1.0, 1.0, -2.0], range_min=-5.0))
    assert lethal_cells(lc) == [[50, 70]]           # only the 1.0 m return, ahead of the sensor
    assert lc.costmap.get_cost(30, 50) == FREE_SPACE  # 1 m behind it: nothing
    assert "2 negative ranges dropped" in caplog.text


@pytest.mark.parametrize("field, value, message", [
    ("angle_min", math.nan, "angle_min is nan"),
    ("angle_increment", math.nan, "angle_increment is nan"),
    ("angle_increment", math.inf, "angle_increment is inf"),
    ("range_max", math.nan, "range_max is nan"),
    ("range_max", math.inf, "range_max is inf"),
    ("range_min", math.nan, "range_min is nan"),
    ("range_min", 6.0, "range_min 6 is not below range_max 5.6"),
    ("angle_increment", 1e308, "3 ranges at angle_increment 1e+308 sweep more than one turn"),
    ("ranges", [1.0] * 100_000, "100000 ranges at angle_increment 0.01 sweep more than one turn"),
    ("ranges", [[1.0, 1.0]], "ranges must be a flat list, got shape (1, 2)"),
    ("sensor_pose", (2.5, 2.5, 0.0, math.nan), "the sensor pose is not finite: (2.5, 2.5, 0.0, nan)"),
])
def test_malformed_scans_change_nothing_and_say_why(caplog, field, value, message):
    baseline = costmap_after(GOOD)
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        lc = costmap_after(GOOD, dict(GOOD, **{field: value}))
    np.testing.assert_array_equal(lc.costmap.costmap, baseline.costmap.costmap)
    assert all(math.isfinite(b) for b in lc.bounds.as_tuple())
    assert f"LaserScan dropped: {message}" in caplog.text


def test_huge_ranges_are_out_of_range_not_obstacles():
    # A LaserScan carries float32, where 1e308 arrives as inf.
    lc = costmap_after(dict(GOOD, ranges=np.array([np.inf, 1.0, np.inf], dtype=np.float32)),
                       dict(GOOD, ranges=[1e308, 1.0, 1e308]))
    assert lethal_cells(lc) == [[50, 70]]
    assert all(math.isfinite(b) for b in lc.bounds.as_tuple())


def test_an_observation_from_a_non_finite_sensor_origin_is_dropped(caplog):
    lc, layer = make_costmap()
    layer.add_observation("scan", point_cloud_to_observation([[3.5, 2.5, 0.0]], SENSOR[:3], 0.0, 15.0, 20.0))
    with caplog.at_level(logging.WARNING, logger=LOGGER):
        layer.add_observation("scan", point_cloud_to_observation([[3.5, 2.5, 0.0]], (math.nan, 2.5, 0.0), 0.0,
                                                                 15.0, 20.0))
        lc.update_map(*SENSOR[:2], 0.0)
    assert lethal_cells(lc) == [[50, 70]]
    assert "observation source 'scan': observation dropped, its sensor origin [nan, 2.5, 0.0] is not finite" \
        in caplog.text
