"""The hostile-input matrix, against a live launch and the command lines: every probe must be refused (or the
robot stopped), with nothing lost. Run it before each release.

    python bench/probe.py

Starts ``navigation world:=lab map:=lab rtf:=1 foxglove:=true respawn:=true`` (every node its own process, amcl and
map_server among them), then, as any other node or program on the machine could:
  - sets hostile move_base, collision monitor and simulator parameters through their parameter services
    (ros2 param set);
  - drives the robot at 1 m/s straight ahead on cmd_vel_nav, as a crazed move_base would, for 25 s (the lab's
    outer wall is at most 15 m away): the collision monitor must stop it short of it, with no collision;
  - opens Foxglove WebSocket handshakes from a foreign web page and with a rebound host name;
  - runs every area's probes in ``bench/probes/*.py``: each module's ``run(session)`` returns its rows (what, input,
    outcome, refused-or-survived) and leaves the robot standing;
  - runs the launcher and the campaign runner with unbounded or malformed arguments.
Afterwards the simulator and move_base must be the processes that started, and an ordinary goal must succeed.
Prints one row per probe: what was sent, what came back, and whether that is a refusal.
"""

from __future__ import annotations

import importlib.util
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[0] = str(ROOT)

from bench.probes._common import set_parameter  # noqa: E402
from simplebot_navigation.scenarios.campaign.execution import domain_lease  # noqa: E402

MOVE_BASE_PROBES = [
    ("local_costmap.footprint", "robot"),
    ("local_costmap.footprint", "[[0, 0], [1, 1]]"),
    ("local_costmap.footprint", "[[0, 0], [nan, 1], [1, 0]]"),
    ("local_costmap.footprint", "[[0.1, 0.1], [0.1, 0.1], [0.1, 0.1]]"),
    ("local_costmap.footprint", "[[0, 0], [0.3, 0.3], [0.3, 0], [0, 0.3]]"),
    ("local_costmap.footprint", "[[0, 0], [1e308, 0], [0, 1]]"),
    ("local_costmap.footprint", str([[round(0.3 * math.cos(a / 3183), 4), round(0.3 * math.sin(a / 3183), 4)]
                                     for a in range(20000)])),
    ("local_costmap.inflation_layer.inflation_radius", 1e6),
    ("global_costmap.inflation_layer.inflation_radius", 150.0),
    ("controller_frequency", 1e308),
    ("controller_frequency", 1e-300),
    ("controller_frequency", 1e-6),
    ("TebLocalPlannerROS.max_vel_x", 1e308),
    ("local_costmap.inflation_layer.inflaton_radius", 1.0),
]
DRIVE_S = 25.0
COLLISION_MONITOR_PROBES = [("footprint", "robot"), ("footprint", "[[0, 0], [1, 1]]"), ("stop_distance", math.nan),
                            ("time_before_collision", 1e308), ("slowdown_distance", 0.01),
                            ("cmd_vel_out_topic", "/elsewhere"), ("stop_distanse", 0.1)]
SIMULATOR_PROBES = [("real_time_factor", -1.0), ("real_time_factor", math.nan), ("physics_rate", 0.0),
                    ("world", "doors"), ("seed", 7), ("use_sim_time", True)]
COMMAND_PROBES = [
    ["-m", "simplebot_navigation.launch", "multi_navigation", "robots:=1000"],
    ["-m", "simplebot_navigation.launch", "multi_navigation", "robots:=99999999999"],
    ["-m", "simplebot_navigation.launch", "navigation", "namespace:=a b"],
    ["-m", "simplebot_navigation.launch", "navigation", "world:=../../etc/passwd"],
    ["-m", "simplebot_navigation.scenarios", "campaign", "--worlds", "lab", "--seeds", "0-99999999999",
     "--out", "/tmp/probe.jsonl"],
    ["-m", "simplebot_navigation.scenarios", "campaign", "--worlds", "lab", "--goals", "library",
     "--out", "/tmp/probe_ray.jsonl", "--ray", "127.0.0.1:1"],
    ["-m", "simplebot_navigation.scenarios", "campaign", "--worlds", "lab", "--goals", "library",
     "--out", "/proc/probe.jsonl"],
]


def short(value, width: int = 46) -> str:
    text = repr(value)
    return text if len(text) <= width else text[:width - 3] + "..."


def handshake(port: int, origin: str | None, host: str) -> str:
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    try:
        with connect(f"ws://{host}:{port}", sock=socket.create_connection(("127.0.0.1", port)), origin=origin,
                     subprotocols=["foxglove.sdk.v1"], open_timeout=10):
            return "connected"
    except InvalidStatus as err:
        return f"HTTP {err.response.status_code}"


def hostile_drive(session) -> tuple[str, str, str, bool]:
    """1 m/s straight ahead on cmd_vel_nav for 25 s (wall clock), then zero: nothing may be hit, and the robot
    ends up standing short of what it was driven at."""
    from geometry_msgs.msg import Twist

    publisher = session.client.create_publisher(Twist, "/cmd_vel_nav", 1)
    ahead, stop = Twist(), Twist()
    ahead.linear.x = 1.0
    collisions, start = session.client.collisions, session.pose()
    session.spin_wall(DRIVE_S - 1.0, lambda: publisher.publish(ahead) and False)
    before_last_second = session.pose()
    session.spin_wall(1.0, lambda: publisher.publish(ahead) and False)
    publisher.publish(stop)
    session.client.destroy_publisher(publisher)
    end = session.pose()
    moved = math.hypot(end.x - start.x, end.y - start.y)
    last_second = math.hypot(end.x - before_last_second.x, end.y - before_last_second.y)
    new = session.client.collisions - collisions
    return (f"cmd_vel_nav 1 m/s ahead for {DRIVE_S:g} s", "a crazed move_base",
            f"drove {moved:.2f} m, {last_second:.2f} m in the last second, {new} collisions",
            new == 0 and last_second < 0.05)


def area_probes() -> list:
    """The ``run(session)`` of every module in bench/probes/, in name order."""
    runs = []
    for path in sorted((ROOT / "bench" / "probes").glob("[!_]*.py")):
        spec = importlib.util.spec_from_file_location(f"probes_{path.stem}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        runs.append(module.run)
    return runs


def main() -> int:
    with domain_lease(os.getpid() % 100, None) as domain:
        os.environ.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        return probe()


def probe() -> int:
    from rclpy.parameter_client import AsyncParameterClient

    from simplebot_navigation.scenarios.process_session import ProcessSession
    from simplebot_navigation.sim.world import Pose2D

    rows: list[tuple[str, str, str, bool]] = []
    with ProcessSession("lab", rtf=1.0, respawn=True, foxglove_port=0, map_name="lab") as session:
        session.wait_ready(wall_timeout_s=240.0)
        pids = {name: session.node_pid(name) for name in ("simulator", "move_base", "collision_monitor",
                                                           "foxglove_bridge", "amcl", "map_server")}
        for node, probes in (("/move_base", MOVE_BASE_PROBES), ("/collision_monitor", COLLISION_MONITOR_PROBES),
                             ("/simulator", SIMULATOR_PROBES)):
            client = AsyncParameterClient(session.client, node)
            for name, value in probes:
                ok, reason = set_parameter(session, client, name, value)
                rows.append((f"param set {node} {name}", short(value), reason or "successful", not ok and reason != ""))
        port = int(next(line.rsplit(":", 1)[1] for line in session.log_text().splitlines()
                        if "Foxglove WebSocket server on ws://" in line).strip())
        for origin, host in (("https://evil.example", "127.0.0.1"), (None, "evil.example"),
                             ("null", "localhost")):
            outcome = handshake(port, origin, host)
            rows.append(("Foxglove handshake", f"Origin {origin}, Host {host}", outcome, outcome == "HTTP 403"))
        rows.append(hostile_drive(session))
        for run in area_probes():
            rows.extend(run(session))
        same = {name: session.node_pid(name) == pid for name, pid in pids.items()}
        run = session.send_goal(Pose2D(3.5, 0.0, 0.0, "corridor"))
        session.spin_wall(120.0, lambda: run.done)
        rows.append(("the same processes afterwards", ", ".join(pids), str(same), all(same.values())))
        rows.append(("the next ordinary goal", "corridor (3.5, 0)", f"{run.status} {run.reason}".strip(),
                     run.status == "SUCCEEDED"))
    for args in COMMAND_PROBES:
        out = subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=120, cwd=ROOT)
        said = (out.stderr.strip().splitlines() or ["(nothing)"])[-1]
        rows.append((" ".join(args[1:3]), short(" ".join(args[3:])), f"exit {out.returncode}: {said}",
                     out.returncode == 2))
    print(f"{'probe':<58} {'input':<48} {'ok':<4} outcome")
    for what, given, outcome, refused in rows:
        print(f"{what:<58} {given:<48} {'yes' if refused else 'NO':<4} {outcome[:150]}")
    failed = sum(not refused for *_, refused in rows)
    print(f"\n{len(rows) - failed} of {len(rows)} probes refused or survived as they must")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
