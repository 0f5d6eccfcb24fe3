"""One campaign run in a process of its own: ``python -m simplebot_navigation.scenarios.campaign.worker RUN OUT``.

RUN is the run's record as JSON, OUT the file the result goes to. The process is started fresh for
every run with its own ROS_DOMAIN_ID already in its environment, so rclpy and DDS never see another
run's nodes, and a crash or a hang takes nothing else down.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile

from simplebot_navigation.scenarios.campaign.spec import Run, robot_body, speed_of, split_parameter_set
from simplebot_navigation.scenarios.report import finite
from simplebot_navigation.scenarios.runner import parse_goals, run_goal, time_budget, world_for_run
from simplebot_navigation.scenarios.session import NavigationSession

READY_TIMEOUT_S = 300.0


def execute(run: Run) -> dict:
    """Start the stack in lockstep for the run's world, body and seed, send its goal, and measure it."""
    body, radius = robot_body(run.robot)
    shipped, overrides = split_parameter_set(run.params)
    with tempfile.TemporaryDirectory(prefix="simplebot_campaign_") as folder, \
            NavigationSession(world_for_run(run.world, run.seed, folder), body, radius, rtf=0.0, seed=run.seed,
                              tight="tight" in shipped, overrides=overrides,
                              collision_monitor="no_collision_monitor" not in shipped,
                              moving_obstacles="no_moving_obstacles" not in shipped,
                              true_obstacles="true_obstacles" in shipped,
                              max_speed=speed_of(run.params)) as session:
        (goal,) = parse_goals(run.goal, session.world)
        session.wait_ready(wall_timeout_s=READY_TIMEOUT_S)
        max_vel_x = session.controller_param("max_vel_x", 0.4)
        budget = run.time_budget or time_budget(session.world, session.pose(), goal, max_vel_x)
        result = run_goal(session, goal, budget)
    record = result.to_dict()
    del record["run"]
    return record


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.splitlines()[0], file=sys.stderr)
        return 2
    run = Run.from_dict(json.loads(argv[0]))
    print(f"campaign run {run.key} in ROS domain {os.environ.get('ROS_DOMAIN_ID')}", flush=True)
    record = finite(execute(run))
    partial = argv[1] + ".partial"
    with open(partial, "w", encoding="utf-8") as handle:
        json.dump(record, handle, allow_nan=False)
    os.replace(partial, argv[1])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
