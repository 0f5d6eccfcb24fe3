"""Goal to first command: how long after a goal the robot is told to move, through Nav2's NavigateToPose and
through move_base's own MoveBase action, side by side in the same run.

    .venv/bin/python bench/nav2_latency.py [--goals 10] [--skip-realtime] [--skip-lockstep]

The robot drives back and forth between two poses 2 m apart in the lab, each goal sent when the one before has
succeeded and the robot stands, alternating the two actions. Measured per goal: from the moment the client sends the
goal to the first cmd_vel with a non-zero velocity on /simplebot_controller/cmd_vel (the zero move_base sends when
it takes a goal does not count).

  lockstep   move_base and the simulator in this process, simulated time stepped by the driver: the latency
             in simulated ms (a control period is 50 ms), free of this machine's load.
  real time  the launcher's processes at real time (rtf:=1): the latency in wall ms as a user sees it,
             DDS and the planner included.

Targets (issue: Nav2's front door): <= 150 ms lockstep, <= 300 ms wall at real time.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

from geometry_msgs.msg import PoseStamped, Twist  # noqa: E402
from nav2_msgs.action import NavigateToPose  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402

from move_base_msgs.action import MoveBase  # noqa: E402
from simplebot_navigation.ros.conversions import quaternion_msg  # noqa: E402
from simplebot_navigation.scenarios import NavigationSession  # noqa: E402
from simplebot_navigation.scenarios.process_session import ProcessSession  # noqa: E402

#: the two poses the robot drives between, in the lab's odom frame (its start is the origin)
POSES = ((2.0, 0.5, 0.0), (0.0, 0.0, 0.0))
GOAL_SIM_S = 40.0


def stamped(x: float, y: float, yaw: float) -> PoseStamped:
    pose = PoseStamped()
    pose.header.frame_id = "odom"
    pose.pose.position.x, pose.pose.position.y = x, y
    pose.pose.orientation = quaternion_msg(yaw)
    return pose


def measure(session, goals: int, clock) -> dict[str, list[float]]:
    """Latencies (ms on ``clock``) of ``goals`` goals, alternating NavigateToPose and MoveBase."""
    node = session.client
    moving: list[float] = []
    node.create_subscription(Twist, "simplebot_controller/cmd_vel",
                             lambda msg: moving.append(clock()) if (msg.linear.x or msg.angular.z) else None, 50)
    clients = {"NavigateToPose": ActionClient(node, NavigateToPose, "navigate_to_pose"),
               "MoveBase": ActionClient(node, MoveBase, "move_base")}
    session.run_until(None, lambda: all(c.server_is_ready() for c in clients.values()), wall_timeout_s=60)
    out: dict[str, list[float]] = {name: [] for name in clients}
    for i in range(goals):
        name = list(clients)[i % 2]
        pose = stamped(*POSES[i % 2])
        goal = NavigateToPose.Goal(pose=pose) if name == "NavigateToPose" else MoveBase.Goal(target_pose=pose)
        session.run_for(0.5)        # the robot stands
        moving.clear()
        sent = clock()
        future = clients[name].send_goal_async(goal)
        session.run_until(None, future.done, wall_timeout_s=60)
        result = future.result().get_result_async()
        session.run_until(session.time + GOAL_SIM_S, result.done, wall_timeout_s=300)
        if not result.done() or result.result().status != 4 or not moving:
            raise RuntimeError(f"goal {i} ({name}) did not succeed: "
                               f"{result.result().status if result.done() else 'no result'}")
        out[name].append((moving[0] - sent) * 1e3)
        print(f"goal {i} ({name}): {out[name][-1]:.0f} ms", flush=True)
    return out


def row(label: str, values: list[float]) -> str:
    v = np.asarray(values)
    return f"| {label} | {len(v)} | {np.median(v):.0f} | {np.percentile(v, 95):.0f} | {v.max():.0f} |"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--goals", type=int, default=10, help="goals per mode, alternating the two actions")
    parser.add_argument("--skip-realtime", action="store_true")
    parser.add_argument("--skip-lockstep", action="store_true")
    args = parser.parse_args()
    if not 2 <= args.goals <= 200:
        parser.error(f"--goals must be in [2, 200], got {args.goals}")
    os.environ.setdefault("ROS_DOMAIN_ID", "57")
    lines = ["| mode, action | goals | median ms | p95 ms | max ms |", "|---|---|---|---|---|"]
    if not args.skip_lockstep:
        with NavigationSession("lab") as session:
            session.wait_ready(120)
            result = measure(session, args.goals, lambda: session.time)
        lines += [row(f"lockstep (sim ms), {name}", values) for name, values in result.items()]
    if not args.skip_realtime:
        with ProcessSession("lab", rtf=1.0) as session:
            session.wait_ready(180)
            result = measure(session, args.goals, time.monotonic)
        lines += [row(f"real time (wall ms), {name}", values) for name, values in result.items()]
    print("\n".join(lines))
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
