"""A killed simulator, respawned: how fast move_base stops the robot, and whether it drives again.

    python bench/simulator_restart.py [--kills 3]

Launches ``navigation`` (each node its own process, respawn on) at real time, and --kills times: sends a goal,
kills the simulator with SIGKILL while the robot drives, measures the wall time to move_base's first zero
cmd_vel, waits for the respawned simulator and the old goal's result, then drives a new goal and times it.
"""

from __future__ import annotations

import argparse
import os
import signal
import time


from simplebot_navigation.scenarios.process_session import ProcessSession
from simplebot_navigation.sim.world import Pose2D

OUT, BACK = Pose2D(4.0, 0.0, 0.0, "corridor"), Pose2D(0.5, 0.0, 3.14159, "start")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kills", type=int, default=3)
    args = parser.parse_args()
    rows = []
    with ProcessSession("lab", rtf=1.0, respawn=True) as session:
        session.wait_ready(wall_timeout_s=240.0)
        commands = session.client.record_commands()
        spin = session.spin_wall

        for kill in range(1, args.kills + 1):
            old = session.send_goal(OUT)
            spin(5.0)
            seen, last_stamp = len(session.client.truth), session.client.truth[-1][0]
            os.kill(session.node_pid("simulator"), signal.SIGKILL)
            killed = time.monotonic()
            spin(1.0)
            zero = next((t - killed for t, v, w in commands if t > killed and v == 0.0 and w == 0.0), None)
            spin(60.0, lambda: old.done)
            spin(60.0, lambda: any(2.0 < t < last_stamp for t, *_ in session.client.truth[seen:]))
            started = time.monotonic()
            new = session.send_goal(OUT)
            spin(120.0, lambda: new.done)
            rows.append((kill, zero, old.status, old.reason, new.status, time.monotonic() - started))
            back = session.send_goal(BACK)
            spin(120.0, lambda: back.done)
    print(f"{'kill':>4}  {'first zero cmd_vel':>18}  {'old goal':>8}  {'new goal':>9}  {'wall s':>6}  reason")
    for kill, zero, old_status, reason, new_status, wall in rows:
        zero_text = f"{zero * 1e3:.0f} ms" if zero is not None else "none"
        print(f"{kill:4d}  {zero_text:>18}  {old_status or '-':>8}  {new_status or '-':>9}  {wall:6.0f}  {reason}")
    with open("/proc/loadavg", encoding="ascii") as loadavg:
        print(f"load average at the end: {loadavg.read().split()[0]}")


if __name__ == "__main__":
    main()
