"""Frontier exploration on small synthetic grids: which frontiers exist, which the robot can reach, their order,
and how the Explorer gives up on goals."""

import math

import numpy as np
import pytest

from simplebot_navigation.maps.map_io import OccupancyMap
from simplebot_navigation.slam.frontier import Explorer, find_frontiers, footprint_cleared, goal_to_send

RES = 0.1
UNKNOWN, FREE, WALL = -1, 0, 100
#: 8-connected travel is at least the straight line and at most 1.083 times it (22.5 deg worst case), plus a cell
#: for where in its cell the robot stands
OCTILE = 1.0 + 2 ** 0.5 * math.sin(math.pi / 8) ** 2 + 1e-6


def grid(height, width, fill=UNKNOWN, origin=(0.0, 0.0, 0.0)):
    return OccupancyMap(np.full((height, width), fill, dtype=np.int8), RES, origin)


def half_seen_room(origin=(0.0, 0.0, 0.0)):
    """A 4 m x 3 m room: its left half seen (walls and free floor), its right half unknown."""
    room = grid(30, 40, origin=origin)
    room.data[:, :20] = WALL
    room.data[1:29, 1:20] = FREE
    return room


def corridor_with_two_frontiers():
    """An 8 m long hall: a small unknown blob (0.6 m of frontier) 0.4 m from the robot at x = 1.05, and the
    unseen far end (2.8 m of frontier) 5.8 m away."""
    hall = grid(30, 80)
    hall.data[:, :70] = WALL
    hall.data[1:29, 1:70] = FREE
    hall.data[14:16, 14:17] = UNKNOWN
    return hall


def test_a_half_seen_room_has_one_frontier_along_the_boundary():
    room = half_seen_room(origin=(-2.0, -1.0, 0.0))
    robot = (-0.95, 0.55)                                # a cell centre, where travel distances start
    [frontier] = find_frontiers(room, robot)
    assert frontier.cells == 28                          # rows 1..28 of the first unknown column
    assert frontier.size == pytest.approx(2.8)
    assert frontier.centroid == pytest.approx((-2.0 + 2.05, -1.0 + 1.5))
    # the goal: a free cell of the last seen column, next to the middle of the frontier (half a cell off: 28 rows)
    assert frontier.goal[0] == pytest.approx(-2.0 + 1.95)
    assert abs(frontier.goal[1] - (-1.0 + 1.5)) <= RES
    straight = math.dist(robot, frontier.goal)
    assert straight - 1e-9 <= frontier.distance <= straight * OCTILE + RES
    assert frontier.cost == pytest.approx(3.0 * frontier.distance - 1.0 * 2.8)


def test_unknown_space_behind_a_wall_is_no_frontier():
    closed = grid(30, 40)
    closed.data[:, :21] = WALL
    closed.data[1:29, 1:20] = FREE                       # column 20 is the wall, unknown beyond it
    assert find_frontiers(closed, (1.0, 1.5)) == []
    closed.data[29, 5:17] = UNKNOWN                      # an unseen stretch of the top wall: a 1.2 m doorway
    [door] = find_frontiers(closed, (1.0, 1.5))
    assert door.centroid == pytest.approx((1.1, 2.95))


def test_a_diagonal_wall_is_not_cut_through():
    room = grid(30, 30, fill=FREE)
    room.data[np.arange(30), np.arange(30)] = WALL       # one cell thick, touching only at corners
    room.data[25:, :3] = UNKNOWN                         # unknown on the far side of it
    assert find_frontiers(room, (2.0, 0.5), clearance=0.01) == []
    assert len(find_frontiers(room, (0.5, 2.0), clearance=0.01)) == 1


def gap_room(gap_cells):
    """The robot's room (x < 2 m), a wall at x = 2.0..2.1 with a gap of ``gap_cells``, a seen room beyond
    (2.1..3 m) and unknown after x = 3 m."""
    rooms = grid(30, 45)
    rooms.data[:, :30] = WALL
    rooms.data[1:29, 1:20] = FREE
    rooms.data[1:29, 21:30] = FREE
    rooms.data[15 - gap_cells // 2:15 - gap_cells // 2 + gap_cells, 20] = FREE
    return rooms


def test_a_frontier_behind_a_gap_narrower_than_the_robot_is_not_offered():
    robot = (0.55, 1.55)
    assert find_frontiers(gap_room(4), robot, clearance=0.3) == []          # 0.4 m gap, 0.6 m robot
    [through_wide] = find_frontiers(gap_room(10), robot, clearance=0.3)     # 1.0 m gap
    [through_narrow] = find_frontiers(gap_room(4), robot, clearance=0.12)   # a 0.24 m robot fits 0.4 m
    for frontier in (through_wide, through_narrow):
        assert frontier.goal[0] == pytest.approx(2.95)
        assert frontier.distance >= math.dist(robot, frontier.goal) - 1e-9


def test_a_robot_hugging_a_wall_still_finds_the_frontier():
    room = half_seen_room()
    [frontier] = find_frontiers(room, (0.15, 1.5), clearance=0.3)        # 0.05 m from the left wall
    assert frontier.goal[0] == pytest.approx(1.95)


def test_frontiers_smaller_than_min_frontier_size_are_dropped():
    room = half_seen_room()
    room.data[10:12, 8:10] = UNKNOWN                     # a 2 x 2 blob: 4 frontier cells, 0.4 m
    sizes = sorted(f.size for f in find_frontiers(room, (0.5, 2.5), min_frontier_size=0.5))
    assert sizes == pytest.approx([2.8])
    sizes = sorted(f.size for f in find_frontiers(room, (0.5, 2.5), min_frontier_size=0.4))
    assert sizes == pytest.approx([0.4, 2.8])           # exactly the minimum is kept, as in explore_lite


def test_cost_order_follows_potential_and_gain_scales():
    hall, robot = corridor_with_two_frontiers(), (1.05, 1.45)
    near_first = find_frontiers(hall, robot, potential_scale=3.0, gain_scale=1.0)
    far_first = find_frontiers(hall, robot, potential_scale=0.1, gain_scale=5.0)
    assert [f.size for f in near_first] == pytest.approx([0.6, 2.8])      # the blob's 6 cells first
    assert [f.size for f in far_first] == pytest.approx([2.8, 0.6])
    near, far = near_first
    assert near.distance < 1.0 < 5.0 < far.distance
    for scales, frontiers in (((3.0, 1.0), near_first), ((0.1, 5.0), far_first)):
        costs = [scales[0] * f.distance - scales[1] * f.size for f in frontiers]
        assert [f.cost for f in frontiers] == pytest.approx(costs)
        assert costs == sorted(costs)


def test_a_fully_known_closed_map_has_nothing_to_explore():
    closed = grid(20, 20, fill=WALL)
    closed.data[1:19, 1:19] = FREE
    assert find_frontiers(closed, (1.0, 1.0)) == []
    assert Explorer().next_goal(closed, (1.0, 1.0), now=0.0) is None


def test_a_failed_goal_is_blacklisted_and_another_frontier_offered():
    hall, robot = corridor_with_two_frontiers(), (1.05, 1.45)
    explorer = Explorer()
    first = explorer.next_goal(hall, robot, now=0.0)
    assert first[0] < 2.0                                # the near blob
    assert explorer.next_goal(hall, robot, now=1.0) == first          # kept while it stays the best
    explorer.goal_failed(first)
    assert explorer.blacklist == (first,)
    second = explorer.next_goal(hall, robot, now=2.0)
    assert second[0] == pytest.approx(6.95)             # the far end of the hall
    explorer.goal_failed(second)
    assert explorer.next_goal(hall, robot, now=3.0) is None


def test_no_progress_for_progress_timeout_blacklists_the_goal():
    hall, robot = corridor_with_two_frontiers(), (1.05, 1.45)
    explorer = Explorer(progress_timeout=30.0)
    goal = explorer.next_goal(hall, robot, now=100.0)
    assert explorer.next_goal(hall, robot, now=129.9) == goal
    assert explorer.next_goal(hall, robot, now=130.0) != goal
    assert explorer.blacklist == (goal,)


def test_progress_towards_the_goal_restarts_the_timeout_but_jitter_does_not():
    hall = corridor_with_two_frontiers()
    explorer = Explorer(progress_timeout=30.0, potential_scale=0.1, gain_scale=5.0)   # the far end first
    goal = explorer.next_goal(hall, (1.05, 0.55), now=0.0)                 # along the hall's side, clear of the blob
    assert goal[0] == pytest.approx(6.95)
    # forward 0.5 m at 20 s, then wobbling 5 cm across a cell border, which shortens the way by a cell (0.1 m)
    for now, x in ((20.0, 1.55), (45.0, 1.55), (49.0, 1.6), (49.9, 1.55)):
        assert explorer.next_goal(hall, (x, 0.55), now=now) == goal
    assert explorer.next_goal(hall, (1.6, 0.55), now=50.0) != goal         # 30 s since the last progress
    assert explorer.blacklist == (goal,)


@pytest.mark.parametrize("robot", [(math.nan, 1.0), (1.0, math.inf), (-0.05, 1.0), (4.0, 1.0), (1.0, 3.0),
                                   (1.0,), "ab", None])
def test_a_bad_robot_position_is_refused(robot):
    with pytest.raises(ValueError, match="robot_xy"):
        find_frontiers(half_seen_room(), robot)


@pytest.mark.parametrize("name, value", [("min_frontier_size", -0.5), ("potential_scale", math.nan),
                                         ("gain_scale", -1.0), ("clearance", 0.0), ("clearance", -0.3),
                                         ("clearance", 50.0), ("clearance", math.inf)])
def test_bad_frontier_parameters_are_refused(name, value):
    with pytest.raises(ValueError, match=name):
        find_frontiers(half_seen_room(), (1.0, 1.0), **{name: value})
    with pytest.raises(ValueError, match=name):
        Explorer(**{name: value})


@pytest.mark.parametrize("name, value", [("progress_timeout", 0.0), ("progress_timeout", math.nan),
                                         ("blacklist_radius", -0.1), ("blacklist_radius", "far")])
def test_bad_explorer_parameters_are_refused(name, value):
    with pytest.raises(ValueError, match=name):
        Explorer(**{name: value})


def test_bad_maps_times_and_goals_are_refused():
    with pytest.raises(ValueError, match="yaw"):
        find_frontiers(half_seen_room(origin=(0.0, 0.0, 0.3)), (1.0, 1.0))
    bad_resolution = half_seen_room()
    bad_resolution.resolution = -0.1
    with pytest.raises(ValueError, match="grid.resolution"):
        find_frontiers(bad_resolution, (1.0, 1.0))
    with pytest.raises(ValueError, match="grid"):
        find_frontiers(np.zeros((10, 10), dtype=np.int8), (1.0, 1.0))
    with pytest.raises(ValueError, match="now"):
        Explorer().next_goal(half_seen_room(), (1.0, 1.0), now=math.nan)
    with pytest.raises(ValueError, match="goal"):
        Explorer().goal_failed((math.nan, 1.0))


# -- where the robot is sent, and the patch under it --------------------------------------------------------------
def room_at_5cm(width_cells=120, height_cells=80):
    """A 6 m x 4 m room at 5 cm, seen free, walled round."""
    data = np.zeros((height_cells, width_cells), dtype=np.int8)
    data[[0, -1], :] = data[:, [0, -1]] = WALL
    return data


def test_a_goal_by_the_unknown_is_sent_back_from_it():
    data = room_at_5cm()
    data[1:-1, 60:-1] = UNKNOWN                                         # the right half not seen
    goal = (59.5 * 0.05, 40.5 * 0.05)                                   # the free cell by the frontier
    target = goal_to_send(OccupancyMap(data, 0.05), goal, clearance=0.35)
    assert target == pytest.approx((50.5 * 0.05, goal[1]))              # 0.45 m from the unknown, straight back


def test_a_goal_in_a_passage_is_looked_at_from_where_the_robot_can_turn():
    data = room_at_5cm()
    data[:, 80:] = WALL
    data[36:54, 80:101] = FREE                                          # a 0.9 m passage, 1.05 m deep
    data[36:54, 101:-1] = UNKNOWN                                       # unseen beyond it
    goal = (100.5 * 0.05, 44.5 * 0.05)
    target = goal_to_send(OccupancyMap(data, 0.05), goal, clearance=0.35)
    assert target == pytest.approx((67.5 * 0.05, goal[1]))              # in the room, 0.75 m from the jambs, in sight
    data[36:54, 80:82] = WALL                                           # the passage shut: the goal is cut off
    assert goal_to_send(OccupancyMap(data, 0.05), goal, clearance=0.35) is None


def test_a_goal_behind_a_pillar_is_sent_to_where_the_goal_is_in_sight():
    data = room_at_5cm()
    data[1:-1, 90:-1] = UNKNOWN
    goal = (89.5 * 0.05, 40.5 * 0.05)
    data[36:46, 70:76] = WALL                                           # a pillar on the straight way back
    target = goal_to_send(OccupancyMap(data, 0.05), goal, clearance=0.35)
    assert target is not None
    row, col = (round(target[1] / 0.05 - 0.5), round(target[0] / 0.05 - 0.5))
    assert not (36 <= row < 46) and math.dist(target, goal) <= 2.0 + 1e-9
    steps = np.linspace(0.0, 1.0, 200)
    line_rows = np.rint(row + steps * (40 - row)).astype(int)
    line_cols = np.rint(col + steps * (89 - col)).astype(int)
    assert not (data[line_rows, line_cols] == WALL).any()                # the goal is in sight from there


def test_the_unknown_patch_under_a_standing_robot_counts_as_free():
    data = room_at_5cm()
    data[36:46, 56:66] = UNKNOWN                                        # 0.5 m square under the robot, never seen
    data[1:-1, 100:-1] = UNKNOWN                                        # a real frontier, far off
    grid = OccupancyMap(data, 0.05)
    robot = (61 * 0.05, 41 * 0.05)
    cleared = footprint_cleared(grid, robot, clearance=0.35)
    assert (cleared.data[36:46, 56:66] == FREE).all()
    assert (cleared.data[1:-1, 100:-1] == UNKNOWN).all()                # the unseen beyond is left alone
    assert (grid.data[36:46, 56:66] == UNKNOWN).all()                   # the map given is not changed
    frontiers = find_frontiers(cleared, robot, clearance=0.35)
    assert len(frontiers) == 1 and frontiers[0].centroid[0] > 4.9
    # without it the robot stands on unknown cells, reaches nothing, and exploration would end at once
    assert find_frontiers(grid, robot, clearance=0.35) == []


def test_a_patch_where_the_robot_turned_is_cleared_after_it_left():
    data = room_at_5cm()
    data[36:46, 26:36] = UNKNOWN                                        # where it turned on the spot
    grid = OccupancyMap(data, 0.05)
    far = (90 * 0.05, 41 * 0.05)
    assert (footprint_cleared(grid, far, clearance=0.35).data[36:46, 26:36] == UNKNOWN).all()
    looked = footprint_cleared(grid, far, looked_from=[(31 * 0.05, 41 * 0.05)], clearance=0.35)
    assert (looked.data[36:46, 26:36] == FREE).all()


def test_unknown_space_open_to_the_rest_is_not_cleared_beyond_the_robot_s_reach():
    data = room_at_5cm()
    data[1:-1, 60:-1] = UNKNOWN                                         # the robot stands at the frontier
    robot = (58 * 0.05, 40.5 * 0.05)
    cleared = footprint_cleared(OccupancyMap(data, 0.05), robot, clearance=0.35)
    now_free = (cleared.data == FREE) & (data == UNKNOWN)
    rows, cols = np.nonzero(now_free)
    assert now_free.any()
    assert np.hypot((cols + 0.5) * 0.05 - robot[0], (rows + 0.5) * 0.05 - robot[1]).max() <= 0.35 + 1e-9


def test_bad_input_to_the_goal_and_footprint_helpers_is_refused():
    grid = OccupancyMap(room_at_5cm(), 0.05)
    with pytest.raises(ValueError, match="goal"):
        goal_to_send(grid, (math.nan, 1.0), clearance=0.35)
    with pytest.raises(ValueError, match="clearance"):
        goal_to_send(grid, (1.0, 1.0), clearance=-1.0)
    with pytest.raises(ValueError, match="looked_from"):
        footprint_cleared(grid, (1.0, 1.0), looked_from=[(1.0,)], clearance=0.35)
    assert goal_to_send(grid, (1e6, 1e6), clearance=0.35) is None       # off the map: nothing to send
    assert (footprint_cleared(grid, (1e6, 1e6), clearance=0.35).data == grid.data).all()
