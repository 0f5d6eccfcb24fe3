"""The MPPI controller's space-time guide (mppi/guide.py) in scripted scenes, without ROS (the scenes of
test_passive_safety.py): it steps aside for an obstacle coming down a corridor, and without a moving obstacle near it
changes nothing."""

import numpy as np

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
