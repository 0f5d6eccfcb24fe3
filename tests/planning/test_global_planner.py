"""global_planner/GlobalPlanner and navfn/NavfnROS on small Costmap2D grids (docs/reference.md §3)."""

import math

import numpy as np
import pytest

from .planner_grids import costs_along, free_map, inflate
from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.planning import (POT_HIGH, GlobalPlanner, GlobalPlannerConfig,
                                           PlanFailure, make_global_planner,
                                           potential_to_occupancy)
from simplebot_navigation.planning import path_kernels
from simplebot_navigation.planning.global_planner import (astar_costs, global_planner_costs,
                                                          navfn_costs)

GP = "global_planner/GlobalPlanner"
NAVFN = "navfn/NavfnROS"


def planner(**params) -> GlobalPlanner:
    return make_global_planner(GP, params)


def euclid(a, b) -> float:
    return math.hypot(b[0] - a[0], b[1] - a[1])


# -- cost mapping -----------------------------------------------------------------------------
def test_global_planner_cost_mapping_has_the_plateau():
    lut = global_planner_costs(253, 50, 3.0, allow_unknown=True)
    assert {c: lut[c] for c in (0, 1, 10, 50, 67, 68, 100, 251)} == {
        0: 50, 1: 53, 10: 80, 50: 200, 67: 251, 68: 252, 100: 252, 251: 252}
    assert lut[255] == 252
    assert np.isinf(lut[[252, 253, 254]]).all()
    assert np.isinf(global_planner_costs(253, 50, 3.0, allow_unknown=False)[255])


def test_navfn_cost_mapping_has_no_plateau():
    lut = navfn_costs(allow_unknown=True)
    assert {c: lut[c] for c in (0, 10, 100, 200, 252, 255)} == {
        0: 50, 10: 58, 100: 130, 200: 210, 252: 251, 255: 253}
    assert np.isinf(lut[[253, 254]]).all()
    assert np.isinf(navfn_costs(allow_unknown=False)[255])


def test_astar_step_cost_ignores_cost_factor():
    lut = astar_costs(253, 50, allow_unknown=True)
    assert (lut[0], lut[100], lut[252], lut[255]) == (50, 150, 302, 305)
    assert np.isinf(lut[[253, 254]]).all()


# -- paths ------------------------------------------------------------------------------------
@pytest.mark.parametrize("params", [{}, {"use_dijkstra": False}, {"use_grid_path": True},
                                    {"use_quadratic": False}])
def test_straight_path_in_free_space(params):
    costmap = free_map()
    start, goal = (0.73, 0.61, 0.0), (5.22, 3.37, 1.0)
    result = planner(**params).make_plan(costmap, start, goal)
    assert result.ok and result.failure is None
    assert result.poses[0, :2] == pytest.approx(start[:2], abs=0.1)
    assert tuple(result.poses[-1]) == pytest.approx(goal)
    straight = euclid(start, goal)
    tol = 0.01 if not params else 0.10  # grid path / 4-neighbour potential: staircase-ish
    assert straight <= result.length + 1e-9 <= straight * (1 + tol) + 0.1
    if not params:
        # Free space: every step costs neutral_cost per cell.
        assert result.cost == pytest.approx(50 * result.length / costmap.resolution)


def test_default_dijkstra_path_starts_exactly_at_the_robot_and_ends_at_the_goal():
    start, goal = (1.0, 1.0, 0.0), (5.0, 3.0, -2.0)
    result = planner().make_plan(free_map(), start, goal)
    assert tuple(result.poses[0, :2]) == pytest.approx(start[:2])
    assert tuple(result.poses[-1]) == pytest.approx(goal)
    assert result.goal == pytest.approx(goal)
    assert result.length <= euclid(start, goal) * 1.01


@pytest.mark.parametrize("params", [{}, {"use_dijkstra": False}, {"use_grid_path": True}])
def test_detour_around_a_wall(params):
    costmap = free_map()
    costmap.costmap[:30, 30] = LETHAL_OBSTACLE  # wall from the bottom, gap at y >= 3.0 m
    start, goal = (1.05, 1.05, 0.0), (5.05, 1.05, 0.0)
    result = planner(**params).make_plan(costmap, start, goal)
    assert result.ok
    assert (costs_along(costmap, result.poses) < LETHAL_OBSTACLE).all()
    assert result.poses[:, 1].max() > 3.0
    assert result.length > 2 * math.hypot(2.0, 3.0 - 1.05) - 0.1  # via the gap corner


def test_goal_in_the_left_half_of_a_cell_next_to_a_wall():
    costmap = free_map()
    costmap.costmap[:30, 30] = LETHAL_OBSTACLE
    # Cell (31, 20); ROS 1 waits for lattice node int(31.2 - 0.5) = 30, the wall, and fails.
    goal = (3.12, 2.05, 0.0)
    result = planner().make_plan(costmap, (1.05, 2.05, 0.0), goal)
    assert result.ok and tuple(result.poses[-1]) == pytest.approx(goal)


def test_path_keeps_away_from_inflated_cost_when_there_is_room():
    costmap = free_map(100, 60)
    costmap.costmap[:25, 45:55] = LETHAL_OBSTACLE  # block up to y = 2.5 m, free above
    inflate(costmap, inscribed_radius=0.3, inflation_radius=1.5, cost_scaling_factor=3.0)
    start, goal = (1.0, 3.0, 0.0), (9.0, 3.0, 0.0)
    straight = np.column_stack([np.linspace(1.0, 9.0, 200), np.full(200, 3.0)])
    assert costs_along(costmap, straight).max() == 102  # cell row 30, 0.6 m from the block
    dijkstra = planner().make_plan(costmap, start, goal)
    assert costs_along(costmap, dijkstra.poses).max() == 0  # room above: zero-cost cells only
    astar = planner(use_dijkstra=False).make_plan(costmap, start, goal)
    assert costs_along(costmap, astar.poses).max() < 40


def test_closed_wall_means_no_path():
    costmap = free_map()
    costmap.costmap[:, 30] = LETHAL_OBSTACLE
    for params in ({}, {"use_dijkstra": False}):
        result = planner(**params).make_plan(costmap, (1.05, 1.05, 0.0), (5.05, 1.05, 0.0))
        assert not result.ok and result.failure is PlanFailure.NO_PATH
        assert result.poses.shape == (0, 3)
        assert result.potential is not None
        # The whole left half was flooded, nothing right of the wall.
        assert (result.potential[1:-1, 1:30] < POT_HIGH).all()
        assert (result.potential[:, 31:] >= POT_HIGH).all()


@pytest.mark.parametrize("params", [{}, {"use_dijkstra": False}])
def test_unknown_space(params):
    costmap = free_map()
    costmap.costmap[:, 30:32] = NO_INFORMATION
    start, goal = (1.05, 1.05, 0.0), (5.05, 1.05, 0.0)
    crossing = planner(allow_unknown=True, **params).make_plan(costmap, start, goal)
    assert crossing.ok
    assert (costs_along(costmap, crossing.poses) == NO_INFORMATION).any()
    blocked = planner(allow_unknown=False, **params).make_plan(costmap, start, goal)
    assert blocked.failure is PlanFailure.NO_PATH

    costmap.costmap[30:, 30:32] = 0  # a gap at the top
    around = planner(allow_unknown=False, **params).make_plan(costmap, start, goal)
    assert around.ok
    assert (costs_along(costmap, around.poses) != NO_INFORMATION).all()


def test_a_plan_is_blocked_by_an_obstacle_seen_after_planning_not_by_unknown_space():
    costmap = free_map()
    costmap.costmap[:, 30:32] = NO_INFORMATION
    gp = planner(allow_unknown=True)
    poses = gp.make_plan(costmap, (1.05, 1.05, 0.0), (5.05, 1.05, 0.0)).poses
    assert not gp.blocked_poses(costmap, poses).any()
    off_map = np.vstack([poses, [[-3.0, 1.0, 0.0]]])
    assert not gp.blocked_poses(costmap, off_map).any()
    costmap.costmap[:, 40] = 252      # a wall's inflation at the inscribed radius edge: impassable for the planner
    blocked = gp.blocked_poses(costmap, poses)
    assert blocked.any() and {int(x / 0.1) for x in poses[blocked, 0]} == {40}
    unknown_blocks = planner(allow_unknown=False).blocked_poses(costmap, poses)
    assert np.argmax(unknown_blocks) < np.argmax(blocked)  # unknown blocks this one earlier


def test_goal_in_unknown_space_is_lethal_when_unknown_is_not_allowed():
    costmap = free_map()
    costmap.costmap[20, 50] = NO_INFORMATION
    result = planner(allow_unknown=False).make_plan(costmap, (1.05, 1.05, 0), (5.05, 2.05, 0))
    assert result.failure is PlanFailure.GOAL_IN_LETHAL


# -- potential --------------------------------------------------------------------------------
def test_quadratic_potential_values_around_an_integer_start():
    costmap = free_map()
    start, goal = (2.05, 2.05, 0.0), (5.55, 3.55, 0.0)  # start cell (20, 20)
    pot = planner(old_navfn_behavior=True).make_plan(costmap, (2.0, 2.0, 0), goal).potential
    assert pot[20, 20] == 0
    assert (pot[20, 21], pot[21, 20], pot[20, 19], pot[19, 20]) == (50, 50, 50, 50)
    assert pot[21, 21] == pytest.approx(50 + 50 * 0.7040, abs=1e-4)
    assert pot[20, 22] == 100
    simple = planner(old_navfn_behavior=True, use_quadratic=False).make_plan(
        costmap, start, goal).potential
    assert simple[21, 21] == 100


INF = float("inf")
# Potentials computed by ROS 1 global_planner (noetic, its C++ DijkstraExpansion/AStarExpansion
# with the QuadraticCalculator and default costs) on ros_map() from cell (2, 2) to (7, 2).
ROS_DIJKSTRA = [
    [INF, INF, INF, INF, INF, INF, INF, INF, INF, INF],
    [INF, 85.2, 50.0, 85.2, 334.746, INF, INF, INF, INF, INF],
    [INF, 50.0, 0.0, 50.0, 302.0, INF, INF, 622.139, 640.692, INF],
    [INF, 85.2, 50.0, 85.2, 334.746, INF, 775.683, 572.139, 594.278, INF],
    [INF, 127.246, 100.0, 127.246, 379.246, INF, 667.833, 522.139, 549.385, INF],
    [INF, 172.139, 150.0, 172.139, 307.333, 413.39, 489.794, 472.139, 507.339, INF],
    [INF, 222.139, 360.94, 222.139, 272.139, 322.139, 372.139, 422.139, 472.139, INF],
    [INF, INF, INF, INF, INF, INF, INF, INF, INF, INF]]
ROS_ASTAR = [  # same map without the unknown cell (ROS 1 wraps 255 + 50 to 49 there)
    [INF, INF, INF, INF, INF, INF, INF, INF, INF, INF],
    [INF, 85.2, 50.0, 85.2, 251.823, INF, INF, INF, INF, INF],
    [INF, 50.0, 0.0, 50.0, 220.0, INF, INF, 625.2, INF, INF],
    [INF, 85.2, 50.0, 85.2, 251.823, INF, 630.521, 575.2, 602.446, INF],
    [INF, 127.246, 100.0, 135.2, 298.363, INF, 535.2, 525.2, 560.4, INF],
    [INF, 172.139, 150.0, 185.2, 265.2, 345.2, 425.2, 475.2, 525.2, INF],
    [INF, 218.553, 200.0, 235.2, 282.179, 332.179, 382.179, 432.179, INF, INF],
    [INF, INF, INF, INF, INF, INF, INF, INF, INF, INF]]


def ros_map(unknown: bool):
    costmap = free_map(10, 8, 1.0)
    grid = costmap.costmap
    grid[1:5, 5] = LETHAL_OBSTACLE  # wall from the bottom
    grid[1:5, 4], grid[1:5, 6], grid[5, 4:7] = 120, 60, 30
    if unknown:
        grid[6, 2] = NO_INFORMATION
    return costmap


@pytest.mark.parametrize("params, unknown, expected", [({}, True, ROS_DIJKSTRA),
                                                       ({"use_dijkstra": False}, False, ROS_ASTAR)])
def test_potentials_match_ros_1(params, unknown, expected):
    # old_navfn_behavior seeds the start cell exactly as ROS 1 does; the border is outlined.
    result = planner(old_navfn_behavior=True, **params).make_plan(
        ros_map(unknown), (2.5, 2.5, 0.0), (7.5, 2.5, 0.0))
    assert result.ok
    pot = np.where(result.potential >= POT_HIGH, np.inf, result.potential)
    assert pot == pytest.approx(np.array(expected), abs=1e-3)


def test_potential_occupancy_grid_scaling():
    pot = np.array([[0.0, 50.0, 100.0, POT_HIGH]], dtype=np.float32)
    assert potential_to_occupancy(pot, 100).tolist() == [[0, 50, 100, -1]]
    assert potential_to_occupancy(pot, 50).tolist() == [[0, 25, 50, -1]]
    assert potential_to_occupancy(np.full((2, 2), POT_HIGH, np.float32), 100).tolist() == [
        [-1, -1], [-1, -1]]


# -- tolerance and failures -------------------------------------------------------------------
def blocked_goal_map():
    costmap = free_map()
    costmap.costmap[15:25, 40:50] = LETHAL_OBSTACLE  # x 4.0..5.0 m, y 1.5..2.5 m
    return costmap


def test_goal_in_lethal_space_with_zero_tolerance_fails_with_its_own_reason():
    result = planner().make_plan(blocked_goal_map(), (1.05, 1.05, 0.0), (4.75, 2.05, 0.0))
    assert result.failure is PlanFailure.GOAL_IN_LETHAL
    assert "254" in result.message


@pytest.mark.parametrize("params", [{}, {"use_dijkstra": False}, {"use_grid_path": True}])
def test_tolerance_ends_at_the_nearest_reachable_cell(params):
    goal = (4.75, 2.05, 0.7)  # cell (47, 20); nearest free cell centre: (5.05, 2.05), 0.3 m
    result = planner(**params).make_plan(blocked_goal_map(), (1.05, 1.05, 0.0), goal,
                                         tolerance=0.5)
    assert result.ok
    assert result.goal == pytest.approx((5.05, 2.05, 0.7))
    assert tuple(result.poses[-1]) == pytest.approx((5.05, 2.05, 0.7))


def test_default_tolerance_applies_when_the_request_has_none():
    goal = (4.75, 2.05, 0.0)
    costmap = blocked_goal_map()
    assert planner(default_tolerance=0.5).make_plan(costmap, (1.05, 1.05, 0), goal).ok
    too_small = planner(default_tolerance=0.2).make_plan(costmap, (1.05, 1.05, 0), goal)
    assert too_small.failure is PlanFailure.NO_PATH
    assert "tolerance" in too_small.message
    assert planner(default_tolerance=0.5).make_plan(costmap, (1.05, 1.05, 0), goal,
                                                    tolerance=0.0).failure is \
        PlanFailure.GOAL_IN_LETHAL


def test_start_and_goal_off_the_costmap():
    costmap = free_map(origin=(-1.0, -1.0))
    p = planner()
    off_start = p.make_plan(costmap, (-1.01, 0.0, 0.0), (1.0, 1.0, 0.0))
    assert off_start.failure is PlanFailure.START_OFF_MAP and off_start.potential is None
    assert "start" in off_start.message
    off_goal = p.make_plan(costmap, (0.0, 0.0, 0.0), (5.0, 0.0, 0.0), tolerance=1.0)
    assert off_goal.failure is PlanFailure.GOAL_OFF_MAP
    assert len({off_start.failure, off_goal.failure, PlanFailure.GOAL_IN_LETHAL,
                PlanFailure.NO_PATH}) == 4


def test_invalid_requests_raise():
    p, costmap = planner(), free_map()
    with pytest.raises(ValueError, match="goal"):
        p.make_plan(costmap, (1, 1, 0), (float("nan"), 1, 0))
    with pytest.raises(ValueError, match="start"):
        p.make_plan(costmap, (1, 1), (2, 2, 0))
    with pytest.raises(ValueError, match="tolerance"):
        p.make_plan(costmap, (1, 1, 0), (2, 2, 0), tolerance=-0.1)


def test_side_effects_on_the_costmap():
    costmap = free_map()
    costmap.costmap[10, 10] = LETHAL_OBSTACLE  # the robot's own cell
    assert planner().make_plan(costmap, (1.05, 1.05, 0.0), (3.05, 2.05, 0.0)).ok
    assert costmap.costmap[10, 10] == 0
    grid = costmap.costmap
    for border in (grid[0], grid[-1], grid[:, 0], grid[:, -1]):
        assert (border == LETHAL_OBSTACLE).all()
    untouched = free_map()
    assert planner(outline_map=False).make_plan(untouched, (1.05, 1.05, 0), (3.05, 2.05, 0)).ok
    assert (untouched.costmap == 0).all()


def test_planning_along_the_map_border_without_outline():
    result = planner(outline_map=False).make_plan(free_map(), (0.05, 0.05, 0.0),
                                                  (5.95, 0.05, 0.0))
    assert result.ok
    assert result.poses[:, 1].max() < 0.2


# -- orientation --------------------------------------------------------------------------------
@pytest.mark.parametrize("mode, yaw", [(0, 0.0), (1, 0.0), (4, math.pi), (5, -math.pi / 2),
                                       (6, math.pi / 2)])
def test_orientation_modes_on_a_straight_path(mode, yaw):
    result = planner(orientation_mode=mode).make_plan(free_map(), (1.05, 2.05, 0.3),
                                                      (5.05, 2.05, 2.0))
    assert result.ok
    assert np.allclose(result.poses[:, 1], 2.05)
    body = np.abs(np.angle(np.exp(1j * (result.poses[:-1, 2] - yaw))))
    assert body.max() < 1e-6
    assert result.poses[-1, 2] == 2.0


def test_interpolate_orientation_blends_start_to_goal():
    result = planner(orientation_mode=2).make_plan(free_map(), (1.05, 2.05, 0.3),
                                                   (5.05, 2.05, 1.3))
    yaw = result.poses[:, 2]
    assert yaw[0] == pytest.approx(0.3) and yaw[-1] == pytest.approx(1.3)
    assert np.all(np.diff(yaw) > 0)


# -- old behaviour, A*, navfn -------------------------------------------------------------------
def test_old_navfn_behavior_uses_cell_corners_and_appends_the_goal_twice():
    goal = (4.0, 3.0, 0.5)
    result = planner(old_navfn_behavior=True, orientation_mode=0).make_plan(
        free_map(), (1.07, 1.02, 0.0), goal)
    assert result.ok
    assert tuple(result.poses[0, :2]) == pytest.approx((1.0, 1.0))  # corner of cell (10, 10)
    assert tuple(result.poses[-1]) == pytest.approx(goal)
    assert tuple(result.poses[-2, :2]) == pytest.approx(goal[:2])


def test_astar_plan_does_not_depend_on_cost_factor():
    costmap = free_map()
    inflate_map = blocked_goal_map()
    inflate(inflate_map, 0.2, 1.0, 3.0)
    for cm in (costmap, inflate_map):
        a = planner(use_dijkstra=False, cost_factor=0.5).make_plan(cm, (1.05, 1.05, 0),
                                                                   (5.55, 3.05, 0))
        b = planner(use_dijkstra=False, cost_factor=5.0).make_plan(cm, (1.05, 1.05, 0),
                                                                   (5.55, 3.05, 0))
        assert np.array_equal(a.poses, b.poses)


def test_make_global_planner_types():
    assert not make_global_planner(GP, {}).config.navfn
    assert make_global_planner(NAVFN, {}).config.navfn
    with pytest.raises(ValueError, match="carrot_planner/CarrotPlanner"):
        make_global_planner("carrot_planner/CarrotPlanner", {})


def test_navfn_mode_plans_without_orientations_and_keeps_the_map_untouched():
    costmap = free_map()
    costmap.costmap[:30, 30] = LETHAL_OBSTACLE
    before = costmap.costmap.copy()
    result = make_global_planner(NAVFN, {"visualize_potential": True}).make_plan(
        costmap, (1.05, 1.05, 0.0), (5.05, 1.05, 0.4))
    assert result.ok
    assert (result.poses[:-1, 2] == 0).all() and result.poses[-1, 2] == 0.4
    assert (costs_along(costmap, result.poses) < LETHAL_OBSTACLE).all()
    assert np.array_equal(costmap.costmap, before)


def test_navfn_tolerance_accepts_a_goal_off_the_map():
    costmap = free_map()
    navfn = make_global_planner(NAVFN, {})
    goal = (6.2, 2.05, 0.0)  # 0.2 m past the right edge
    assert navfn.make_plan(costmap, (1.05, 2.05, 0), goal).failure is PlanFailure.GOAL_OFF_MAP
    result = navfn.make_plan(costmap, (1.05, 2.05, 0), goal, tolerance=0.5)
    assert result.ok
    end = result.poses[-1]
    # navfn scans goal + k * resolution; the border column (x >= 5.9 m) is blocked.
    assert end[0] == pytest.approx(6.2 - 0.5 + 0.1 * 1) and end[1] == pytest.approx(2.05)
    assert euclid(end, goal) <= 0.5


def test_navfn_goal_in_obstacle_with_and_without_tolerance():
    navfn = make_global_planner(NAVFN, {})
    fail = navfn.make_plan(blocked_goal_map(), (1.05, 1.05, 0), (4.75, 2.05, 0))
    assert fail.failure is PlanFailure.GOAL_IN_LETHAL
    ok = navfn.make_plan(blocked_goal_map(), (1.05, 1.05, 0), (4.75, 2.05, 0), tolerance=0.5)
    assert ok.ok and ok.goal[:2] == pytest.approx((5.05, 2.05))


@pytest.mark.parametrize("params", [{}, {"use_dijkstra": False}, {"use_grid_path": True}])
def test_goal_in_the_start_cell_even_when_boxed_in(params):
    costmap = free_map()
    costmap.costmap[9:12, 9:12] = LETHAL_OBSTACLE  # the robot's cell is cleared, the ring stays
    result = planner(**params).make_plan(costmap, (1.02, 1.03, 0.0), (1.08, 1.07, 0.5))
    assert result.ok
    assert tuple(result.poses[-1]) == pytest.approx((1.08, 1.07, 0.5))
    assert result.length < 0.1


def test_planner_accepts_a_config_object():
    cfg = GlobalPlannerConfig.from_params({"publish_potential": False})
    assert GlobalPlanner(cfg).make_plan(free_map(), (1, 1, 0), (2, 2, 0)).ok


def padded(pot: np.ndarray) -> np.ndarray:
    out = np.full((pot.shape[0] + 2, pot.shape[1] + 2), POT_HIGH, np.float32)
    out[1:-1, 1:-1] = pot
    return out.ravel()


def test_gradient_path_steps_over_a_saddle_and_stops_in_a_pit():
    x, y = np.meshgrid(np.arange(11), np.arange(7))
    saddle = padded(50.0 * (5 - np.abs(x - 5)) + 30.0 * np.abs(y - 3))  # ridge along x = 5
    points, count, status = path_kernels.gradient_path(saddle, 13, 1.0, 3.0, 5.0, 3.0, 1000)
    assert status == 0  # ROS 1 stops at the zero gradient of the goal node
    assert points[count - 1].tolist() == [1.0, 3.0]
    assert np.allclose(points[:count, 1], 3.0) and np.all(np.diff(points[:count, 0]) < 0)
    pit = padded(50.0 * np.abs(x - 5) + 30.0 * np.abs(y - 3))
    assert path_kernels.gradient_path(pit, 13, 1.0, 3.0, 5.0, 3.0, 1000)[2] == 3
