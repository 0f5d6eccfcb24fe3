"""ObstacleLayer and observation handling (docs/reference.md §2.5, docs/design.md §9), and the lab stack against the
per-ray reference."""

import math

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.costmap_core import CostmapCore
from simplebot_navigation.costmap.layered_costmap import LayeredCostmap
from simplebot_navigation.costmap.observation import (ObservationSource, laser_scan_to_observation,
                                                      point_cloud_to_observation)
from simplebot_navigation.costmap.obstacle_layer import ObstacleLayer

from simplebot_navigation.testing import costmap_scene as scenario
from simplebot_navigation.testing.costmap_reference import ReferenceCostmap
from simplebot_navigation.testing.lab_params import global_costmap_params, local_costmap_params


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def make_layer(rolling=False, size=100, res=0.05, origin=(0.0, 0.0), track_unknown=False, **source_kwargs):
    clock = Clock()
    lc = LayeredCostmap(rolling, track_unknown, size, size, res, *origin, clock=clock, update_period=0.1)
    kwargs = dict(marking=True, clearing=True, obstacle_range=15.0, raytrace_range=20.0)
    kwargs.update(source_kwargs)
    layer = ObstacleLayer("obstacles", [ObservationSource("scan", data_type="LaserScan", **kwargs)],
                          footprint_clearing_enabled=False)
    lc.add_plugin(layer)
    lc.set_footprint([[0.1, 0.1], [0.1, -0.1], [-0.1, -0.1], [-0.1, 0.1]])
    return lc, layer, clock


def one_beam_scan(distance, sensor=(0.5, 2.5, 0.0, 0.0), **kw):
    """A single beam straight along the sensor's x axis."""
    args = dict(obstacle_range=15.0, raytrace_range=20.0)
    args.update(kw)
    return laser_scan_to_observation([distance], 0.0, 0.01, 0.2, 5.6, sensor, 0.0, **args)


def test_moved_obstacle_is_raytraced_away():
    lc, layer, _ = make_layer()
    layer.add_observation("scan", one_beam_scan(3.0))         # hit at x = 3.5 m -> cell 70
    lc.update_map(0.5, 2.5, 0.0)
    assert lc.costmap.get_cost(70, 50) == LETHAL_OBSTACLE
    layer.add_observation("scan", one_beam_scan(4.0))         # the obstacle moved 1 m further away
    lc.update_map(0.5, 2.5, 0.0)
    assert lc.costmap.get_cost(70, 50) == FREE_SPACE
    assert lc.costmap.get_cost(90, 50) == LETHAL_OBSTACLE
    assert int((lc.costmap.costmap == LETHAL_OBSTACLE).sum()) == 1


def test_nan_and_out_of_range_returns_are_dropped():
    obs = laser_scan_to_observation([np.nan, 0.1, 5.6, 7.0, 2.0, -np.inf], 0.0, 0.1, 0.2, 5.6,
                                    (0, 0, 0.15, 0), 0.0, 15.0, 20.0, inf_is_valid=True)
    assert len(obs.points) == 1 and obs.points[0] == pytest.approx([2.0 * math.cos(0.4), 2.0 * math.sin(0.4), 0.15])
    assert len(obs.clear_points) == 0


def test_inf_is_valid_clears_to_range_max_but_never_marks():
    lc, layer, _ = make_layer(size=200, inf_is_valid=True)
    for x in (30, 100, 150):
        layer.set_cost(x, 50, LETHAL_OBSTACLE)
    obs = one_beam_scan(np.inf, sensor=(0.5, 2.5, 0.0, 0.0), inf_is_valid=True)
    assert len(obs.points) == 0 and obs.clear_points[0][0] == pytest.approx(0.5 + 5.6 - 1e-4)
    layer.add_observation("scan", obs)
    lc.update_map(0.5, 2.5, 0.0)
    assert layer.get_cost(30, 50) == FREE_SPACE and layer.get_cost(100, 50) == FREE_SPACE
    assert layer.get_cost(150, 50) == LETHAL_OBSTACLE      # beyond range_max: untouched
    assert not (lc.costmap.costmap[:, 31:149] == LETHAL_OBSTACLE).any()


def test_inf_without_inf_is_valid_neither_clears_nor_marks():
    lc, layer, _ = make_layer()
    layer.set_cost(30, 50, LETHAL_OBSTACLE)
    layer.add_observation("scan", one_beam_scan(np.inf))
    lc.update_map(0.5, 2.5, 0.0)
    assert layer.get_cost(30, 50) == LETHAL_OBSTACLE


def test_obstacle_range_is_3d_and_exclusive():
    lc, layer, _ = make_layer(obstacle_range=1.0)
    layer.add_observation("scan", point_cloud_to_observation([[1.5, 2.5, 0.0], [1.225, 2.5, 0.0],
                                                              [0.5, 2.5, 1.0]], (0.5, 2.5, 0.0), 0.0, 1.0, 3.0))
    lc.update_map(0.5, 2.5, 0.0)
    # 1.0 m away in x, or straight above by 1.0 m: not marked; 0.725 m away: marked
    assert np.argwhere(lc.costmap.costmap == LETHAL_OBSTACLE).tolist() == [[50, 24]]


def test_height_filter_and_layer_max_height():
    lc, layer, _ = make_layer(min_obstacle_height=0.05, max_obstacle_height=1.0)
    pts = [[1.0, 2.5, 0.01], [1.5, 2.5, 0.5], [2.0, 2.5, 1.5]]
    layer.add_observation("scan", point_cloud_to_observation(pts, (0.5, 2.5, 0.2), 0.0, 15.0, 20.0))
    lc.update_map(0.5, 2.5, 0.0)
    lethal = np.argwhere(lc.costmap.costmap == LETHAL_OBSTACLE)
    assert lethal.tolist() == [[50, 30]]


def test_marking_only_source_does_not_clear():
    lc, layer, _ = make_layer(clearing=False)
    layer.set_cost(30, 50, LETHAL_OBSTACLE)
    layer.add_observation("scan", one_beam_scan(3.0))
    lc.update_map(0.5, 2.5, 0.0)
    assert layer.get_cost(30, 50) == LETHAL_OBSTACLE and layer.get_cost(70, 50) == LETHAL_OBSTACLE


def test_persistence_keeps_recent_observations():
    lc, layer, clock = make_layer(observation_persistence=0.5, clearing=False)
    for k, y in enumerate((1.0, 2.0, 3.0)):
        clock.now = 0.3 * k
        layer.add_observation("scan", point_cloud_to_observation([[1.0, y, 0.0]], (0.5, 2.5, 0.0), 0.3 * k,
                                                                 15.0, 20.0))
    assert [o.stamp for o in layer.buffers["scan"].get_observations()] == [0.6, 0.3]
    lc2, layer2, _ = make_layer(observation_persistence=0.0)
    for stamp in (0.0, 0.1):
        layer2.add_observation("scan", one_beam_scan(1.0))
    assert len(layer2.buffers["scan"].get_observations()) == 1


def test_is_current_allows_one_update_period_of_slack():
    lc, layer, clock = make_layer(expected_update_rate=0.1)
    layer.add_observation("scan", one_beam_scan(1.0))
    clock.now = 0.19                                         # 0.1 s rate + 0.1 s update period
    lc.update_map(0.5, 2.5, 0.0)
    assert lc.is_current()
    clock.now = 0.21
    lc.update_map(0.5, 2.5, 0.0)
    assert not lc.is_current() and lc.stale_sources() == ["obstacles/scan"]
    layer.add_observation("scan", one_beam_scan(1.0))
    lc.update_map(0.5, 2.5, 0.0)
    assert lc.is_current() and lc.stale_sources() == []


def test_zero_expected_update_rate_is_always_current():
    lc, layer, clock = make_layer(expected_update_rate=0.0)
    clock.now = 1e6
    lc.update_map(0.5, 2.5, 0.0)
    assert lc.is_current()


def test_rolling_window_keeps_obstacles_in_place():
    lc, layer, _ = make_layer(rolling=True, track_unknown=True)
    lc.update_map(0.0, 0.0, 0.0)
    ox = lc.costmap.origin_x
    layer.add_observation("scan", point_cloud_to_observation([[1.0, 0.0, 0.0]], (0.0, 0.0, 0.0), 0.0, 15.0, 20.0))
    lc.update_map(0.0, 0.0, 0.0)
    layer.clear_observations()
    lc.update_map(0.26, 0.0, 0.0)                            # 4.45 cells -> the grid moves 4 cells
    assert (ox, lc.costmap.origin_x) == (pytest.approx(-2.45), pytest.approx(-2.25))
    assert lc.costmap.world_to_map(1.0, 0.0) is not None
    mx, my = lc.costmap.world_to_map(1.0, 0.0)
    assert lc.costmap.get_cost(mx, my) == LETHAL_OBSTACLE
    assert layer.get_cost(99, 50) == NO_INFORMATION          # newly exposed columns are unknown


def test_footprint_clearing_frees_the_robot_cells():
    lc, layer, _ = make_layer()
    layer.footprint_clearing_enabled = True
    layer.costmap[45:56, 45:56] = LETHAL_OBSTACLE
    lc.update_map(2.5, 2.5, 0.0)
    assert layer.get_cost(50, 50) == FREE_SPACE and layer.get_cost(45, 45) == LETHAL_OBSTACLE


def test_unsupported_data_type_is_rejected():
    with pytest.raises(ValueError, match="'PointCloud'.*LaserScan, PointCloud2"):
        ObservationSource("scan", data_type="PointCloud")


@pytest.mark.parametrize("params, steps", [(local_costmap_params, 6), (global_costmap_params, 4)])
def test_lab_costmaps_match_the_per_ray_reference(params, steps):
    clock = Clock()
    cm = CostmapCore("costmap", params(), clock=clock)
    c = cm.config
    ref = ReferenceCostmap(c.size_x, c.size_y, c.resolution, c.origin_x, c.origin_y, c.rolling_window, True,
                           [tuple(p) for p in cm.footprint], 1.5, 8.0)
    for k, (x, y, yaw) in enumerate(scenario.robot_path(steps)):
        clock.now = 0.1 * k
        observations = []
        for laser in scenario.LASERS:
            pose = scenario.laser_pose(x, y, yaw, laser)
            ranges = scenario.scan_ranges(pose[0], pose[1], pose[3])
            cm.add_laser_scan(laser, ranges, scenario.ANGLE_MIN, scenario.ANGLE_INCREMENT, scenario.RANGE_MIN,
                              scenario.RANGE_MAX, pose, clock.now)
            observations.append(cm.layer("obstacles").buffers[laser].get_observations()[0])
        cm.update_map(x, y, yaw)
        window = ref.update(x, y, yaw, observations)
        assert cm.update_window == window
        np.testing.assert_array_equal(cm.costmap.costmap, np.array(ref.master, np.uint8))
        assert cm.is_current()
    assert (cm.costmap.costmap == LETHAL_OBSTACLE).sum() > 20


def test_recovery_clearing_forgets_obstacles_outside_the_square():
    cm = CostmapCore("local_costmap", local_costmap_params())
    cm.update_map(0.0, 0.0, 0.0)
    layer = cm.layer("obstacles")
    layer.costmap[:] = LETHAL_OBSTACLE
    assert cm.clear_layers_outside(0.0, 0.0, 1.0) == ["obstacles"]
    mx, my = layer.world_to_map(0.0, 0.0)
    assert layer.get_cost(mx, my) == LETHAL_OBSTACLE and layer.get_cost(mx + 9, my) == LETHAL_OBSTACLE
    assert layer.get_cost(mx + 10, my) == NO_INFORMATION and layer.get_cost(0, 0) == NO_INFORMATION
    cm.update_map(0.0, 0.0, 0.0)
    assert cm.update_window == (0, 0, 100, 100)


def test_forget_history_after_a_backward_time_jump_drops_observations_of_the_old_timeline():
    clock = Clock()
    cm = CostmapCore("local_costmap", local_costmap_params(), clock=clock)
    clock.now = 60.0
    x, y, yaw = next(iter(scenario.robot_path(1)))
    for laser in scenario.LASERS:
        pose = scenario.laser_pose(x, y, yaw, laser)
        cm.add_laser_scan(laser, scenario.scan_ranges(pose[0], pose[1], pose[3]), scenario.ANGLE_MIN,
                          scenario.ANGLE_INCREMENT, scenario.RANGE_MIN, scenario.RANGE_MAX, pose, clock.now)
    cm.update_map(x, y, yaw)
    assert (cm.costmap.costmap == LETHAL_OBSTACLE).any()

    clock.now = 0.5                                   # the simulator restarted
    cm.forget_history()
    layer = cm.layer("obstacles")
    assert all(not buffer.get_observations() for buffer in layer.buffers.values())
    cm.update_map(x, y, yaw)
    assert not (cm.costmap.costmap == LETHAL_OBSTACLE).any(), "old obstacles came back from the buffers"
    assert cm.is_current(), "sensors are judged from the jump on"
