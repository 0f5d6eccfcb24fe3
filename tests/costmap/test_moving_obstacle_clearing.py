"""A person walking past leaves no marks behind once the tracker's clearing circles reach the costmap
(docs/reference.md §6.3), while static walls stay."""

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.costmap.costmap_core import CostmapCore
from simplebot_navigation.perception import ObstacleTracker
from simplebot_navigation.testing.lab_params import local_costmap_params
from simplebot_navigation.testing.lidar_scenes import Cylinder, scans_at

PERSON = Cylinder(0.25, (1.2, -2.4), (0.0, 1.0))
WALL_X = 2.0
SOURCES = ("front_laser", "back_laser")


def walk_past(track: bool, raytrace: bool, check=None) -> CostmapCore:
    """The lab's local costmap around a standing robot while PERSON walks past a wall; the sources' clearing
    flag follows `raytrace`, and with `track` the tracker's circles go in before every update."""
    params = local_costmap_params()
    for source in SOURCES:
        params["obstacles"][source]["clearing"] = raytrace
    now = [0.0]
    cm = CostmapCore("local_costmap", params, clock=lambda: now[0])
    tracker = ObstacleTracker()
    rng = np.random.default_rng(3)
    for k in range(50):
        now[0] = t = 0.1 * k
        for source, scan in zip(SOURCES, scans_at((0.0, 0.0, 0.0), t, [PERSON], [(WALL_X, -2.5, WALL_X, 2.5)], rng=rng)):
            yaw = float(scan.angles[0])
            cm.add_laser_scan(source, scan.ranges, 0.0, float(scan.angles[1] - scan.angles[0]), scan.range_min,
                              scan.range_max, (*scan.origin, 0.15, yaw), t)
            tracker.update([scan], t)
        if track:
            cm.set_clearing_circles(tracker.clearing_circles(t))
        cm.update_map(0.0, 0.0, 0.0)
        if check is not None:
            check(cm, t)
    return cm


def lethal_on_the_path(cm: CostmapCore, below_y: float) -> int:
    """Marked cells of the person's lane whose y lies below below_y."""
    xs, ys = np.meshgrid(np.arange(cm.costmap.size_x), np.arange(cm.costmap.size_y))
    wx = cm.costmap.origin_x + (xs + 0.5) * cm.costmap.resolution
    wy = cm.costmap.origin_y + (ys + 0.5) * cm.costmap.resolution
    lane = (np.abs(wx - PERSON.start[0]) < 0.45) & (wy < below_y)
    return int((cm.costmap.costmap[lane] == LETHAL_OBSTACLE).sum())


def passed_a_second_ago(t: float) -> float:
    """Cells of the lane below this y were left by the person's back edge more than 1 s before t."""
    return PERSON.state(t - 1.0)[0][1] - PERSON.radius


@pytest.mark.parametrize("raytrace", [False, True], ids=["marking only", "lab sources"])
def test_marks_on_the_path_are_gone_within_a_second_and_the_wall_stays(raytrace):
    stale = []

    def check(cm, t):
        if t >= 1.5:
            count = lethal_on_the_path(cm, passed_a_second_ago(t))
            if count:
                stale.append(f"t={t:.1f}: {count} marked cells left more than 1 s ago")

    cm = walk_past(track=True, raytrace=raytrace, check=check)
    assert not stale, "\n".join(stale)
    mx, _ = cm.costmap.world_to_map(WALL_X + 0.01, 0.0)
    column = cm.costmap.costmap[:, mx - 1:mx + 2].max(axis=1)
    assert (column[5:-5] == LETHAL_OBSTACLE).all(), "wall cells were cleared"


def test_without_the_circles_marks_stay_behind():
    cm = walk_past(track=False, raytrace=False)
    assert lethal_on_the_path(cm, passed_a_second_ago(4.9)) > 10


def test_clearing_circles_clear_marks_only_and_ignore_bad_rows():
    cm = CostmapCore("local_costmap", local_costmap_params())
    cm.update_map(0.0, 0.0, 0.0)
    layer = cm.layer("obstacles")
    mx, my = layer.world_to_map(1.0, 1.0)
    layer.costmap[my - 8:my + 9, mx - 8:mx + 9] = NO_INFORMATION
    layer.costmap[my, mx - 8:mx + 9] = LETHAL_OBSTACLE
    cm.set_clearing_circles([[1.0, 1.0, 0.2], [np.nan, 0.0, 1.0], [0.0, 0.0, -1.0], [np.inf, 1.0, 0.1]])
    assert len(layer.clearing_circles) == 1
    cm.update_map(0.0, 0.0, 0.0)
    row = layer.costmap[my, mx - 8:mx + 9]          # cell centres 1.025 + 0.05 k, k = -8..8: within 0.25 m for k = -5..4
    assert (row[3:13] == FREE_SPACE).all() and (row[:3] == LETHAL_OBSTACLE).all() and (row[13:] == LETHAL_OBSTACLE).all()
    assert layer.costmap[my + 2, mx] == NO_INFORMATION                   # unknown stays unknown
    cm.set_clearing_circles(np.empty((0, 3)))
