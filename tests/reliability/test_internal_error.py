"""A bug inside a planner (an exception in the control cycle) stops the robot and aborts the goal with the
error; move_base keeps running and drives the next goal."""

import pytest

from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D

pytestmark = pytest.mark.timeout(240)


def test_an_exception_in_the_local_planner_aborts_the_goal_and_stops_the_robot(capfd):
    with NavigationSession("lab") as session:
        session.wait_ready(wall_timeout_s=120.0)
        controller = session.move_base.controller
        compute, calls = controller.compute, []

        def broken():
            calls.append(session.time)
            if len(calls) == 40:             # two seconds into the goal, while driving
                return 1 / 0
            return compute()

        controller.compute = broken
        commands = session.client.record_commands()
        run = session.send_goal(Pose2D(4.0, 0.0, 0.0, "corridor"))
        session.run_until(session.time + 30.0, lambda: run.done, wall_timeout_s=120.0)
        assert run.status == "ABORTED"
        assert run.reason.startswith("internal error in the control cycle: ZeroDivisionError: division by zero")
        session.run_for(1.0, wall_timeout_s=60.0)
        assert commands[-1][1:] == (0.0, 0.0) and session.move_base.state == "IDLE"
        assert "Traceback" in capfd.readouterr().err

        controller.compute = compute
        again = session.send_goal(Pose2D(4.0, 0.0, 0.0, "corridor"))
        session.run_until(session.time + 60.0, lambda: again.done, wall_timeout_s=120.0)
        assert again.status == "SUCCEEDED"
