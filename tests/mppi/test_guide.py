"""The MPPI controller's space-time guide (mppi/guide.py) in scripted scenes, without ROS (the scenes of
test_passive_safety.py): it steps aside for an obstacle coming down a corridor, and without a moving obstacle near it
changes nothing; obstacles beyond the bounds of a real one are dropped before they reach it."""

import numpy as np
import pytest

from simplebot_navigation.costmap.footprint import footprint_from_radius
from simplebot_navigation.mppi import MppiConfig, MppiController
from simplebot_navigation.mppi.plugin import speed_parameters
from tests.mppi.test_passive_safety import costmap_with, drive


def test_without_a_moving_obstacle_near_the_guide_changes_no_command():
    far = (60.0, 40.0, 0.0, 0.0, 0.3)       # beyond what the horizon can bring near
    walls = [(-2.0, 1.2, 10.0, 1.5), (-2.0, -1.5, 10.0, -1.2), (3.0, -0.4, 3.4, 0.1)]
    on = drive(costmap_with(walls), far, 0.0, 6.0, 6.0)
    off = drive(costmap_with(walls), far, 0.0, 6.0, 6.0, space_time_guide=False)
    assert [row[:6] for row in on] == [row[:6] for row in off]
    assert on[-1][1] > 4.0


def test_an_obstacle_coming_down_a_corridor_is_passed_beside_it():
    """A 3 m corridor and an obstacle of radius 0.4 m walking down its middle at 1 m/s, head-on: there is room
    beside it (0.6 m to spare), none in front of it. The robot takes a side, passes without contact and goes on."""
    walls = [(-2.0, 1.5, 10.0, 1.8), (-2.0, -1.8, 10.0, -1.5)]
    trace = drive(costmap_with(walls), (8.0, 0.0, -1.0, 0.0, 0.4), 0.0, 9.0, 10.0)
    gaps = np.array([row[6] for row in trace])
    assert gaps.min() > 0.0, f"contact at t = {trace[int(np.argmin(gaps))][0]:.2f} s"
    assert trace[-1][1] > 6.0, f"stuck at x = {trace[-1][1]:.2f} m"
    passing = min(trace, key=lambda row: abs(row[1] - (8.0 - row[0])))     # where the obstacle passes the robot
    assert abs(passing[2]) > 0.6, f"beside it by only {abs(passing[2]):.2f} m"


@pytest.mark.parametrize("row", [(1e308, 0.0, 0.0, 0.0, 0.3), (1.0, 0.0, 1e308, 0.0, 0.3), (2.0, 0.0, 0.0, 0.0, 1e308),
                                 (1e300, 1e300, -1e300, 1e300, 0.5), (1.5, 0.0, 0.0, 0.0, 1e6)])
def test_an_obstacle_beyond_the_bounds_is_dropped_and_the_commands_stay_finite(row):
    """Rows a hostile or broken source could hand over in-process (the ROS path refuses them before): each is
    dropped with one warning naming the bounds, and the next cycles, with a real obstacle, command finite speeds."""
    controller = MppiController(MppiConfig.from_params(speed_parameters(1.0)), footprint_from_radius(0.25), 0.05)
    controller.set_plan(np.column_stack([np.linspace(0.0, 10.0, 100), np.zeros(100), np.zeros(100)]))
    costmap = costmap_with([])
    controller.set_dynamic_obstacles(np.array([row]))
    first = controller.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0), costmap)
    notices = controller.pop_notices()
    assert len(notices) == 1 and "beyond 10000 m" in notices[0][1] and "radius of 5 m" in notices[0][1], notices
    controller.set_dynamic_obstacles(np.array([[3.0, 0.5, -1.0, 0.0, 0.4]]))
    after = controller.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0), costmap)
    assert first.ok and after.ok and np.isfinite([first.v, first.omega, after.v, after.omega]).all()

