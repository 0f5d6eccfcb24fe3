import math

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.footprint import footprint_costs, footprint_radii
from simplebot_navigation.teb.feasibility import is_trajectory_feasible

from .scenes import LAB_PADDED_FOOTPRINT


def empty_map():
    return Costmap2D(100, 100, 0.05, -2.5, -2.5)


def wall_map(x_wall: float):
    cm = empty_map()
    cm.costmap[:, cm.world_to_map(x_wall, 0.0)[0]] = LETHAL_OBSTACLE
    return cm


def straight_band(length: float, n: int):
    return np.column_stack([np.linspace(0, length, n + 1), np.zeros(n + 1), np.zeros(n + 1)])


def test_wall_across_the_path_is_infeasible():
    inscribed = footprint_radii(LAB_PADDED_FOOTPRINT)[0]
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
    inscribed = footprint_radii(LAB_PADDED_FOOTPRINT)[0]
    # two poses 2 m apart; the wall at x = 1.0 touches neither footprint, only the swept path
    band = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    cm = wall_map(1.0)
    assert footprint_costs(cm, LAB_PADDED_FOOTPRINT, band).tolist() == [0.0, 0.0]
    assert not is_trajectory_feasible(cm, LAB_PADDED_FOOTPRINT, inscribed, band, 5, -1.0, math.pi)
