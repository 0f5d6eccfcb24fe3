"""The MPPI local planner (docs/reference.md §4.10) end to end, in lockstep: the round body at 1 m/s through an easy
crowd, with the crowd campaign's set and the planner selected as a campaign's parameter set selects it."""

import pytest

from simplebot_navigation.mppi.plugin import MPPI_LOCAL_PLANNER
from tests.e2e.test_moving_obstacles import CROWD, assert_crossed, drive

pytestmark = [pytest.mark.timeout(1200), pytest.mark.e2e]


def test_the_round_robot_crosses_an_easy_crowd_with_mppi():
    assert_crossed("crowd:6", *drive("crowd:6", CROWD + (f"base_local_planner={MPPI_LOCAL_PLANNER}",)))
