"""The office world: big enough for SLAM, a corridor loop around the central block, every goal reachable for the
lab's box robot, no mirror symmetry, and it builds and drives in pybullet."""

import dataclasses
import math

import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import ConvexHull

from simplebot_description import robot_description
from simplebot_navigation.sim import SimplebotSim, Wall, load_world
from simplebot_navigation.sim.map_export import export_map
from simplebot_navigation.sim.office import CENTRAL_BLOCK, CORE, CORRIDOR_LOOP

BOX = robot_description("box")
RESOLUTION = 0.05
#: the lab's costmap footprint (the box plus footprint_padding 0.03), and the disc the box sweeps turning on the spot
RADII = {"padded box": BOX.inscribed_radius + 0.03, "turning box": BOX.circumscribed_radius}
MIN_LOOP_M = 60.0


@pytest.fixture(scope="module")
def office():
    return load_world("office")


def reachable(world, radius):
    """(reachable, map): the cells of the exported map where the centre of a disc of ``radius`` can go from the start.

    An occupied cell's obstacle may lie anywhere in it, up to half a diagonal from its centre, so the clearance
    counts from there: a cell called free is free."""
    occupancy_map = export_map(world, RESOLUTION)
    occupied = occupancy_map.data == 100
    clearance = (ndimage.distance_transform_edt(~occupied) - math.sqrt(0.5)) * RESOLUTION
    labels, _ = ndimage.label(clearance > radius)
    start = labels[cell(occupancy_map, world.start.x, world.start.y)]
    assert start, f"the start is blocked for a disc of radius {radius}"
    return labels == start, occupancy_map


def cell(occupancy_map, x, y):
    ox, oy, _ = occupancy_map.origin
    return math.floor((y - oy) / RESOLUTION), math.floor((x - ox) / RESOLUTION)


def hole_around(free, occupancy_map, x, y):
    """The cells around (x, y) that the reachable region encloses (8-connected, the dual of its 4-connection),
    or None if they reach the map's edge, i.e. the region does not go round (x, y)."""
    labels, _ = ndimage.label(~free, structure=np.ones((3, 3)))
    label = labels[cell(occupancy_map, x, y)]
    edges = np.concatenate((labels[0], labels[-1], labels[:, 0], labels[:, -1]))
    return None if label == 0 or label in edges else labels == label


def loop_bound(world, radius):
    """The shortest loop the disc could drive around the central block, at least: the perimeter of the convex
    hull of what the reachable region encloses there (a closed curve is no shorter than the convex hull of what it
    encloses); None if there is no loop around it."""
    free, occupancy_map = reachable(world, radius)
    block_x, block_y = (CENTRAL_BLOCK[0] + CENTRAL_BLOCK[2]) / 2, (CENTRAL_BLOCK[1] + CENTRAL_BLOCK[3]) / 2
    hole = hole_around(free, occupancy_map, block_x, block_y)
    if hole is None:
        return None
    rows, cols = np.nonzero(hole)
    return ConvexHull(np.column_stack((cols, rows)) * RESOLUTION).area  # a 2-D hull's "area" is its perimeter


def test_office_loads_by_name_with_room_to_turn_at_every_goal(office):
    # load_world checks that the start and every goal are this far from every obstacle.
    office = load_world("office", robot_radius=BOX.circumscribed_radius)
    xmin, ymin, xmax, ymax = office.bounds()
    assert xmax - xmin >= 40.0 and ymax - ymin >= 30.0
    names = [g.name for g in office.goals]
    assert len(set(names)) == len(names)
    assert sum(name.startswith("room_") for name in names) >= 10
    assert {"corridor_nw", "corridor_ne", "corridor_se"} <= set(names)


def test_the_start_is_in_the_corridor_facing_along_it(office):
    (x0, y0), (x1, _) = CORRIDOR_LOOP[0], CORRIDOR_LOOP[1]
    assert office.start.y == y0 and x0 < office.start.x < x1       # on the south leg's centre line
    assert office.start.yaw == 0.0                                  # facing east, along that leg


@pytest.mark.parametrize("radius", RADII.values(), ids=RADII.keys())
def test_every_goal_is_reachable_from_the_start(office, radius):
    free, occupancy_map = reachable(office, radius)
    assert [g.name for g in office.goals if not free[cell(occupancy_map, g.x, g.y)]] == []


@pytest.mark.parametrize("radius", RADII.values(), ids=RADII.keys())
def test_the_corridor_is_a_loop_of_at_least_60_m_around_the_central_block(office, radius):
    assert loop_bound(office, radius) >= MIN_LOOP_M
    # The corridor's centre line is such a loop: every point of it reachable, and it goes round the core.
    free, occupancy_map = reachable(office, radius)
    corners = np.array(CORRIDOR_LOOP + CORRIDOR_LOOP[:1])
    points = np.concatenate([np.linspace(a, b, int(np.hypot(*(b - a)) / RESOLUTION) + 1)
                             for a, b in zip(corners[:-1], corners[1:])])
    assert all(free[cell(occupancy_map, x, y)] for x, y in points)
    assert np.sum(np.hypot(*np.diff(corners, axis=0).T)) >= MIN_LOOP_M
    (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
    assert x0 < CORE[0] and CORE[2] < x1 and y0 < CORE[1] and CORE[3] < y1


def test_a_wall_across_the_corridor_breaks_the_loop(office):
    east_leg_x = CORRIDOR_LOOP[1][0]
    cut = Wall((east_leg_x - 1.5, -7.0), (east_leg_x + 1.5, -7.0))
    assert loop_bound(dataclasses.replace(office, walls=office.walls + (cut,)), RADII["padded box"]) is None


def test_the_office_is_not_mirror_symmetric(office):
    occupied = export_map(office, RESOLUTION).data == 100
    # Shifts of a few cells absorb the map's origin being rounded to a whole cell. A plan symmetric about an axis
    # overlaps its mirror image almost wholly (the doors world: 99 %); the shell and the long corridor walls
    # overlap in any plan, a good third of the office's occupied cells.
    for mirrored in (occupied[:, ::-1], occupied[::-1, :], occupied[::-1, ::-1]):
        overlap = max(np.sum(occupied & np.roll(mirrored, (dr, dc), axis=(0, 1)))
                      for dr in range(-3, 4) for dc in range(-3, 4))
        assert overlap < 0.5 * occupied.sum()


def test_the_box_robot_drives_along_the_corridor_in_pybullet(office):
    with SimplebotSim(office, BOX) as sim:
        while sim.sim_time < 3.0 - 1e-9:
            sim.set_cmd_vel(0.5, 0.0)
            sim.step_until(sim.sim_time + 0.1)
        pose, scans = sim.ground_truth(), sim.due_scans()
        assert sim.collisions().count == 0
    # 3 s at up to 0.5 m/s, east along the corridor's centre line.
    assert 0.8 < pose.x - office.start.x < 1.5 and abs(pose.y - office.start.y) < 0.05
    front = [scan for scan in scans if scan.frame == "front_laser_link"][-1]
    assert np.min(front.ranges) < 1.0              # the corridor's walls, 0.9 m to either side
