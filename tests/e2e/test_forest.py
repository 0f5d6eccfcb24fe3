"""Forests of the benchmark set, in lockstep: the round body r = 0.25 m with the narrow-passage set (tight) at the
lab's speed and at 1 m/s, as `campaign --worlds forest:... --robots round:0.25 --set tight ...` runs them.
At 1 m/s the turn rate and both accelerations go up with the speed (max_vel_theta and acc_lim_theta 1.0,
acc_lim_x 1.0) and the band's poses come closer (dt_ref 0.15 s), so they stay 0.15 m apart."""

import pytest

from simplebot_navigation.scenarios import NavigationSession, run_goal
from simplebot_navigation.scenarios.runner import time_budget

pytestmark = [pytest.mark.timeout(1200), pytest.mark.e2e]

AT_ONE_METRE_PER_SECOND = ("TebLocalPlannerROS.max_vel_x=1.0", "TebLocalPlannerROS.acc_lim_x=1.0",
                           "TebLocalPlannerROS.max_vel_theta=1.0", "TebLocalPlannerROS.acc_lim_theta=1.0",
                           "TebLocalPlannerROS.dt_ref=0.15", "TebLocalPlannerROS.dt_hysteresis=0.015")


@pytest.mark.parametrize("world, overrides", [
    ("forest:24", ()),                         # 0.875 m narrowest passage; failed while move_base planned for r = 0.3
    ("forest:26", AT_ONE_METRE_PER_SECOND),    # 0.775 m, the narrowest of the first campaign's worlds
    ("forest:92", AT_ONE_METRE_PER_SECOND),    # turning at 0.3 rad/s (TEB's default), the robot hit a cylinder
])
def test_the_narrow_passage_set_crosses_a_forest(world, overrides):
    with NavigationSession(world, robot="round", radius=0.25, tight=True, overrides=overrides) as session:
        session.wait_ready(wall_timeout_s=120)
        goal = session.world.goal("exit")
        max_vel_x = session.controller_param("max_vel_x", 0.4)
        result = run_goal(session, goal, time_budget(session.world, session.pose(), goal, max_vel_x),
                          wall_timeout_s=600)
        assert result.success, result.failures
        assert result.collisions == 0 and result.min_clearance > 0.02
        assert result.time_ratio < 1.6, f"{result.time_s:.1f} s for {result.path_length:.1f} m at {max_vel_x} m/s"
