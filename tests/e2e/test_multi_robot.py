"""Three robots in the lab, each with its own move_base, swap places through the shared corridor.

``multi_navigation`` runs as the launcher's processes at real time; goals go to each robot's
/robotK/move_base action stamped in the common ``map`` frame. robot1 (open-plan office) drives to
robot2's start (north meeting room), robot2 to robot3's (the lab) and robot3 to robot1's, so robot2
and robot3 meet in the corridor and at the lab's door: they must see each other in their lidars and
keep apart. robot2 reaches the lab's door just as robot3 comes out of it; before the obstacle
tracker cleared the marks a passing robot leaves, robot2 stood about 30 s in front of robot3's
stale marks. With the obstacle tracker on (obstacle_tracking.enabled, for every robot's move_base) no robot
may stand still for more than STANDING_LIMIT_S while its goal is active: long enough for one robot to wait while
another comes through a door on a loaded machine (6.4 s seen in CI beside the rest of the suite, 2 s alone), far
below the 30 s of waiting on stale marks.
Which topics each move_base uses is checked from a separate process.
"""

import itertools
import json
import math
import subprocess
import sys

import pytest

from move_base_msgs.action import MoveBase
from simplebot_navigation.ros.conversions import quaternion_msg
from simplebot_navigation.scenarios.process_session import ProcessSession
from simplebot_navigation.scenarios.session import ScenarioClient
from simplebot_navigation.sim.world import Pose2D
from simplebot_navigation.sim.world_loader import load_world

pytestmark = [pytest.mark.timeout(900), pytest.mark.e2e]

#: three move_bases and the simulator need about 1.4 cores at real time (bench/realtime.py: 29 % of a core per
#: move_base), and the suite runs another test module beside this one on CI's two cores. Slower did not help: at
#: 0.85 robot1 and robot2 touched in CI, at 0.7 robot2 gave up in the corridor and the swap's six minutes beside the
#: rest made the watchdog test late; at real time it passed in CI three times before and touched once
RTF = 1.0
NAMESPACES = ("robot1", "robot2", "robot3")
DRIVE_WALL_S = 480.0
STANDING_LIMIT_S = 10.0
#: slower than this (m/s, over a ground-truth sample) is standing
STANDING_SPEED = 0.02
#: names every node may share: the clock, TF, diagnostics and ROS's own
SHARED = {"/clock", "/tf", "/tf_static", "/diagnostics", "/rosout", "/parameter_events"}

LIST_TOPICS = """
import json, sys, time, rclpy
rclpy.init()
node = rclpy.create_node("topic_lister")
expected = json.loads(sys.argv[1])   # [topic, node]: node "" for any


def graph():
    found = {}
    for topic, _ in node.get_topic_names_and_types():
        ends = node.get_publishers_info_by_topic(topic) + node.get_subscriptions_info_by_topic(topic)
        found[topic] = sorted({(e.node_namespace.rstrip("/") + "/" + e.node_name) for e in ends})
    return found


# Discovery of five processes' endpoints takes a few seconds, more on a loaded machine: wait for what is expected.
end = time.monotonic() + 60.0
while time.monotonic() < end and not all(t in g and (not n or n in g[t]) for g in [graph()] for t, n in expected):
    rclpy.spin_once(node, timeout_sec=0.1)
end = time.monotonic() + 1.0
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
print(json.dumps(graph()))
"""
TOPICS = ("move_base_simple/goal", "move_base/status", "move_base/_action/feedback", "simplebot_controller/cmd_vel",
          "cmd_vel_nav",
          "simplebot_controller/odom", "front_laser/front_scan", "back_laser/back_scan", "global_costmap/costmap",
          "local_costmap/costmap", "simplebot/collisions")


def topic_graph(expected: list[tuple[str, str]]) -> dict[str, list[str]]:
    """topic -> the nodes (full names) publishing or subscribing it, as another process sees the graph once it
    has discovered the expected (topic, node) ends (node "": any), or after a minute."""
    out = subprocess.run([sys.executable, "-c", LIST_TOPICS, json.dumps(expected)], capture_output=True, text=True,
                         timeout=120, check=True)
    return json.loads(out.stdout)


def goal_in_map(pose) -> MoveBase.Goal:
    goal = MoveBase.Goal()
    goal.target_pose.header.frame_id = "map"
    goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = pose.x, pose.y
    goal.target_pose.pose.orientation = quaternion_msg(pose.yaw)
    return goal


def closest_approach(clients) -> float:
    """The smallest distance between two robots' base_links, over the ground truth stamps they share."""
    tracks = [{t: (x, y) for t, x, y, _ in client.truth} for client in clients]
    return min(math.dist(a[t], b[t]) for a, b in itertools.combinations(tracks, 2) for t in a.keys() & b.keys())


def longest_standstill(truth, t0: float, t1: float) -> tuple[float, float]:
    """(seconds, start) of the longest stretch between t0 and t1 in which the robot stood still."""
    samples = [s for s in truth if t0 <= s[0] <= t1]
    longest, began, since = 0.0, math.nan, None
    for (ta, xa, ya, _), (tb, xb, yb, _) in zip(samples, samples[1:]):
        if tb > ta and math.hypot(xb - xa, yb - ya) / (tb - ta) < STANDING_SPEED:
            since = ta if since is None else since
            if tb - since > longest:
                longest, began = tb - since, since
        else:
            since = None
    return longest, began


def test_three_robots_swap_places_without_touching():
    starts = load_world("lab").starts
    goals = starts[1:] + starts[:1]
    with ProcessSession("lab", rtf=RTF, launch_file="multi_navigation",
                        overrides=("obstacle_tracking.enabled=true",)) as session:
        clients = [ScenarioClient(session.context, namespace) for namespace in NAMESPACES]
        for client in clients:
            session.executor.add_node(client)
        assert session.spin_wall(240.0, lambda: all(c.action.server_is_ready() and c.truth for c in clients)), \
            "the three move_base actions never became ready"

        graph = topic_graph([(f"/{namespace}/{topic}", "") for namespace in NAMESPACES for topic in TOPICS]
                            + [(f"/{namespace}/simplebot_controller/odom", f"/{namespace}/move_base")
                               for namespace in NAMESPACES])
        for namespace in NAMESPACES:
            for topic in TOPICS:
                assert f"/{namespace}/{topic}" in graph, f"/{namespace}/{topic} missing"
            move_base = f"/{namespace}/move_base"
            outside = [t for t, nodes in graph.items() if move_base in nodes
                       and t not in SHARED and not t.startswith(f"/{namespace}/")]
            assert not outside, f"{move_base} uses topics outside its namespace: {outside}"
            assert move_base in graph[f"/{namespace}/simplebot_controller/odom"], "TEB's odometry is not remapped"

        for client, start in zip(clients, starts):
            _, x, y, _ = client.truth[-1]
            assert math.hypot(x - start.x, y - start.y) < 0.05, (client.get_namespace(), x, y, start)

        sent = [client.action.send_goal_async(goal_in_map(goal)) for client, goal in zip(clients, goals)]
        assert session.spin_wall(30.0, lambda: all(f.done() for f in sent))
        assert all(f.result().accepted for f in sent)
        results = [f.result().get_result_async() for f in sent]
        t0 = session.time
        finished = session.spin_wall(DRIVE_WALL_S, lambda: all(r.done() for r in results))
        report = {c.get_namespace(): (c.truth[-1][1:3], c.collisions) for c in clients}
        assert finished, f"not every robot finished within {DRIVE_WALL_S} s: {report}"
        closest = closest_approach(clients)
        print(f"swap took {session.time - t0:.1f} s of simulated time; closest approach {closest:.2f} m; {report}")
        # robot1 passed the others in the corridor (otherwise the test proves little): closer than 2 m.
        assert closest < 2.0, closest

        for client, result in zip(clients, results):
            name = client.get_namespace()
            # Standing still until the goal's end counts only up to the last movement: a robot at its goal stands.
            moved = [s[0] for s, n in zip(client.truth, client.truth[1:]) if math.hypot(n[1] - s[1], n[2] - s[2]) > 1e-3]
            standing, since = longest_standstill(client.truth, t0, moved[-1] if moved else t0)
            print(f"{name}: longest standstill while driving {standing:.1f} s (from t = {since:.1f} s)")
            assert standing <= STANDING_LIMIT_S, f"{name} stood {standing:.1f} s from t = {since:.1f} s"
        for client, goal, result in zip(clients, goals, results):
            name = client.get_namespace()
            assert result.result().status == 4, f"{name}: status {result.result().status}"  # SUCCEEDED
            _, x, y, _ = client.truth[-1]
            assert math.hypot(x - goal.x, y - goal.y) < 0.5, (name, x, y, goal)
            assert client.collisions == 0, f"{name} touched something {client.collisions} time(s)"
        for client in clients:
            client.destroy_node()


def test_one_robot_in_a_namespace_takes_goals_there():
    with ProcessSession("lab", rtf=RTF, namespace="robot1") as session:
        session.wait_ready(wall_timeout_s=240.0)
        graph = topic_graph([("/robot1/cmd_vel_nav", "/robot1/move_base"),
                             ("/robot1/simplebot_controller/cmd_vel", "/robot1/collision_monitor")])
        assert "/robot1/move_base" in graph["/robot1/cmd_vel_nav"]          # move_base -> its collision monitor
        assert "/robot1/collision_monitor" in graph["/robot1/simplebot_controller/cmd_vel"]   # -> the base
        assert "/simplebot_controller/cmd_vel" not in graph and "/move_base/status" not in graph
        goal = Pose2D(1.5, 3.5, math.pi / 2)  # the north meeting room; sent in robot1/odom
        run = session.send_goal(goal)
        assert session.spin_wall(DRIVE_WALL_S, lambda: run.done), "the goal did not finish"
        assert run.status == "SUCCEEDED", (run.status, run.reason)
        final = session.pose()
        assert math.hypot(final.x - goal.x, final.y - goal.y) < 0.5, final
        assert session.client.collisions == 0

