"""The MPPI controller's passive safety in scripted scenes, without ROS: the robot follows each command exactly (a
unicycle stepped every control period), the obstacles move at constant velocity and are handed over as the tracker
would, and the local costmap holds the walls, inflated by the robot's radius."""

import math

import numpy as np
from scipy.ndimage import distance_transform_edt

from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.footprint import footprint_from_radius
from simplebot_navigation.mppi import MppiConfig, MppiController
from simplebot_navigation.mppi.controller import LethalDistance
from simplebot_navigation.mppi.plugin import speed_parameters

RADIUS = 0.25
PERIOD = 0.05
RESOLUTION = 0.025


def costmap_with(walls) -> Costmap2D:
    """A 12 x 6 m costmap from x = -2, y = -3 with lethal boxes (x0, y0, x1, y1), inflated to the inscribed radius."""
    costmap = Costmap2D(480, 240, RESOLUTION, -2.0, -3.0)
    x = costmap.origin_x + (np.arange(costmap.size_x) + 0.5) * RESOLUTION
    y = costmap.origin_y + (np.arange(costmap.size_y) + 0.5) * RESOLUTION
    xx, yy = np.meshgrid(x, y)
    lethal = np.zeros(xx.shape, dtype=bool)
    for x0, y0, x1, y1 in walls:
        lethal |= (xx >= x0) & (xx <= x1) & (yy >= y0) & (yy <= y1)
    if lethal.any():
        near = distance_transform_edt(~lethal) * RESOLUTION <= RADIUS
        costmap.costmap[near] = INSCRIBED_INFLATED_OBSTACLE
    costmap.costmap[lethal] = LETHAL_OBSTACLE
    return costmap


def drive(costmap, obstacle, start_speed: float, goal_x: float, seconds: float, **params):
    """The robot from (0, 0, 0) at start_speed along the plan to (goal_x, 0) among one obstacle (x, y, vx, vy, r);
    per control period: time, robot (x, y, yaw, v, w), the gap between the bodies, the decision's kind."""
    cfg = MppiConfig.from_params({**speed_parameters(1.0), **params})
    controller = MppiController(cfg, footprint_from_radius(RADIUS), PERIOD)
    controller.set_plan(np.column_stack([np.linspace(0.0, goal_x, 200), np.zeros(200), np.zeros(200)]))
    robot = np.array([0.0, 0.0, 0.0, start_speed, 0.0])
    trace = []
    for k in range(round(seconds / PERIOD)):
        t = k * PERIOD
        ox, oy = obstacle[0] + t * obstacle[2], obstacle[1] + t * obstacle[3]
        gap = math.hypot(ox - robot[0], oy - robot[1]) - RADIUS - obstacle[4]
        controller.set_dynamic_obstacles(np.array([[ox, oy, obstacle[2], obstacle[3], obstacle[4]]]),
                                         np.zeros((1, 4, 4)))
        result = controller.compute_velocity_commands(robot[:3], robot[3:], costmap)
        trace.append((t, *robot, gap, result.kind))
        v, w = (result.v, result.omega) if result.ok else (0.0, 0.0)
        mid = robot[2] + 0.5 * w * PERIOD
        robot = np.array([robot[0] + v * PERIOD * math.cos(mid), robot[1] + v * PERIOD * math.sin(mid),
                          robot[2] + w * PERIOD, v, w])
    return trace


def test_an_ambush_finds_the_robot_at_rest():
    """A dead end 0.9 m wide and an obstacle coming down it: there is no way past and hardly any back, so the
    contact cannot be avoided; the robot, which drove towards it at 0.8 m/s, stands still when it comes."""
    walls = [(-2.0, 0.45, 10.0, 1.0), (-2.0, -1.0, 10.0, -0.45), (-1.0, -1.0, -0.5, 1.0)]
    trace = drive(costmap_with(walls), (5.0, 0.0, -1.2, 0.0, 0.3), 0.8, 8.0, 5.0)
    contact = next(row for row in trace if row[6] <= 0.0)
    t, x, y, yaw, v, w, gap, kind = contact
    assert t > 1.0                          # the scene leaves time to stop, not to get away
    assert abs(v) < 1e-6 and abs(w) < 1e-6, f"moving at contact (t = {t:.2f} s): v {v:.3f}, w {w:.3f} ({kind})"
    before = [row for row in trace if row[0] < t]
    assert max(row[4] for row in before) > 0.5 and all(row[1] > -0.3 for row in before)   # it drove, then stopped


def test_a_crossing_obstacle_is_let_past_or_passed_behind():
    """An obstacle crosses the path 2.5 m ahead just when the robot would get there: the robot never touches it
    and still gets past the crossing."""
    trace = drive(costmap_with([]), (2.5, -2.5, 0.0, 1.0, 0.4), 0.0, 6.0, 10.0)
    closest = min(row[6] for row in trace)
    assert closest > 0.0, f"contact: the gap came down to {closest:.3f} m"
    assert trace[-1][1] > 4.0, f"stuck at x = {trace[-1][1]:.2f} m"


def test_the_distance_to_lethal_cells_follows_the_costmap_in_place_and_its_window():
    """The controller keeps the distance field between cycles; a costmap changed in place, or rolled, is seen."""
    distance = LethalDistance()
    costmap = Costmap2D(40, 40, RESOLUTION, -0.5, -0.5)
    assert np.isinf(distance(costmap)).all()
    costmap.costmap[20, 30] = LETHAL_OBSTACLE
    first = distance(costmap)
    np.testing.assert_allclose(first, distance_transform_edt(costmap.costmap != LETHAL_OBSTACLE) * RESOLUTION)
    assert distance(costmap) is first                                    # nothing changed: kept
    costmap.costmap[5, 5] = LETHAL_OBSTACLE
    second = distance(costmap)
    assert second is not first and second[5, 5] == 0.0 and second[6, 5] == RESOLUTION
    costmap.origin_x += RESOLUTION                                       # the window rolled, the cells alike
    assert distance(costmap) is not second and distance(costmap)[5, 5] == 0.0
