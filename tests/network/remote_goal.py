"""One goal to a stack that runs elsewhere, as a user's node on another host would send it; prints the
outcome (scenarios.GoalResult) as one JSON line. Run inside a network namespace by test_two_hosts.py:

    python remote_goal.py WORLD X Y YAW BUDGET_S WALL_TIMEOUT_S
"""

import dataclasses
import json
import sys
import time

from simplebot_navigation.scenarios import RemoteSession, run_goal
from simplebot_navigation.sim.world import Pose2D


def main() -> None:
    world, x, y, yaw, budget_s, wall_timeout_s = sys.argv[1], *map(float, sys.argv[2:7])
    deadline = time.monotonic() + wall_timeout_s
    with RemoteSession(world) as session:
        session.wait_ready(wall_timeout_s=wall_timeout_s)
        result = run_goal(session, Pose2D(x, y, yaw, "remote goal"), budget_s,
                          wall_timeout_s=max(1.0, deadline - time.monotonic()))
    print(json.dumps(dataclasses.asdict(result)), flush=True)


if __name__ == "__main__":
    main()
