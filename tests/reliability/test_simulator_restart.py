"""The simulator process is killed in the middle of a goal and the launcher respawns it: simulated time starts
again from zero. move_base must stop the robot at once, drop what belongs to the old timeline, and take the
next goal with no manual step."""

import os
import signal
import time

import pytest

from simplebot_navigation.scenarios.process_session import ProcessSession
from simplebot_navigation.sim.world import Pose2D


@pytest.mark.timeout(420)
def test_a_killed_and_respawned_simulator_stops_the_robot_then_the_next_goal_succeeds():
    with ProcessSession("lab", rtf=1.0, respawn=True) as session:
        session.wait_ready(wall_timeout_s=240.0)
        commands = session.client.record_commands()
        goal = Pose2D(4.0, 0.0, 0.0, "corridor")
        first = session.send_goal(goal)
        assert session.spin_wall(60.0, lambda: any(abs(v) > 0.05 for _, v, _ in commands[-10:])), \
            "the robot should be driving"
        session.spin_wall(2.0)

        old_pid = session.node_pid("simulator")
        seen, last_stamp = len(session.client.truth), session.client.truth[-1][0]
        os.kill(old_pid, signal.SIGKILL)
        killed = time.monotonic()
        session.spin_wall(1.0)
        stops = [t - killed for t, v, w in commands if t > killed and v == 0.0 and w == 0.0]
        assert stops and stops[0] <= 0.5, f"first zero command {stops[:1]} s after the simulator was killed"
        print(f"first zero command {stops[0]:.3f} s after the simulator was killed")
        moving = [(v, w) for t, v, w in commands if t > killed + 0.5 and (v != 0.0 or w != 0.0)]
        assert not moving, f"move_base kept commanding {moving[:3]} with the simulator dead"

        assert session.spin_wall(60.0, lambda: session.node_pid("simulator") not in (None, old_pid)), \
            "the launcher did not respawn the simulator"
        assert session.spin_wall(60.0, lambda: first.done), "the goal of the old timeline never ended"
        # the result and /move_base/status are separate channels: the reason may come a moment after the result
        session.spin_wall(5.0, lambda: bool(first.reason))
        assert first.status == "ABORTED" and "time jumped back" in first.reason, (first.status, first.reason)

        assert session.spin_wall(60.0, lambda: any(2.0 < t < last_stamp for t, *_ in session.client.truth[seen:])), \
            "no ground truth from the new timeline"
        assert session.client.action.server_is_ready()
        second = session.send_goal(goal)
        assert session.spin_wall(120.0, lambda: second.done), "the goal after the restart did not finish"
        assert second.status == "SUCCEEDED", (second.status, second.reason)
        final = session.pose()
        assert abs(final.x - goal.x) < 0.5 and abs(final.y - goal.y) < 0.5, final
        log = session.log_text()
        assert "transform buffer cleared" in log and "costmaps cleared" in log
        assert session.process.poll() is None, "the launcher must still be running"
