"""Three robots in the lab, each with its own move_base, swap places through the shared corridor
(simplebot_navigation/scenarios/swap.py): robot2 and robot3 meet in the corridor and at the lab's door, and must see
each other in their lidars and keep apart.

The swap runs in lockstep, in this process, so its outcome cannot depend on the machine's load; bench/swap.py runs
it at real time as the launcher's processes. Before the obstacle tracker cleared the marks a passing robot leaves,
robot2 stood about 30 s in front of robot3's stale marks: with it no robot may stand still for more than
STANDING_LIMIT_S while its goal is active. Which topics each move_base uses is checked from a separate process, and
the namespaced single robot runs as the launcher's processes.
"""

import json
import math
import subprocess
import sys

import pytest

from simplebot_navigation.scenarios.process_session import ProcessSession
from simplebot_navigation.scenarios.session import WARM_UP_S, NavigationSession, ScenarioClient, goal_in_map
from simplebot_navigation.scenarios.swap import NAMESPACES, closest_approach, longest_standstill, swap_goals
from simplebot_navigation.sim.world import Pose2D

pytestmark = [pytest.mark.timeout(900), pytest.mark.e2e]

RTF = 1.0
#: simulated seconds the three goals may take (the swap takes about 60 s)
DRIVE_S = 300.0
#: wall-clock guard of a lockstep run: it advances as fast as the machine lets it
WALL_S = 700.0
DRIVE_WALL_S = 480.0
STANDING_LIMIT_S = 10.0
#: names every node may share: the clock, TF, diagnostics and ROS's own
#: topics every robot shares: /map is the one map of the building (the obstacle tracker's static_map_topic)
SHARED = {"/clock", "/tf", "/tf_static", "/diagnostics", "/rosout", "/parameter_events", "/map"}

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


def test_three_robots_swap_places_without_touching():
    with NavigationSession("lab", launch_file="multi_navigation") as session:
        clients = [ScenarioClient(session.context, namespace) for namespace in NAMESPACES]
        for client in clients:
            session.driver.add_node(client)
        move_bases = [node for node in session.nodes if node.get_name() == "move_base"]
        assert [m.get_namespace() for m in move_bases] == [f"/{namespace}" for namespace in NAMESPACES]

        def ready():
            return all(c.action.server_is_ready() and c.truth for c in clients) and all(
                m.global_costmap.is_current() and m.local_costmap.is_current() for m in move_bases)
        session.run_until(WARM_UP_S, wall_timeout_s=WALL_S)
        assert session.run_until(None, ready, wall_timeout_s=WALL_S), "the three move_bases never became ready"

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

        starts = session.world.starts
        for client, start in zip(clients, starts):
            _, x, y, _ = client.truth[-1]
            assert math.hypot(x - start.x, y - start.y) < 0.05, (client.get_namespace(), x, y, start)

        goals = swap_goals(starts)
        sent = [client.action.send_goal_async(goal_in_map(goal)) for client, goal in zip(clients, goals)]
        assert session.run_until(None, lambda: all(f.done() for f in sent), wall_timeout_s=WALL_S)
        assert all(f.result().accepted for f in sent)
        results = [f.result().get_result_async() for f in sent]
        t0 = session.time
        finished = session.run_until(t0 + DRIVE_S, lambda: all(r.done() for r in results), wall_timeout_s=WALL_S)
        report = {c.get_namespace(): (c.truth[-1][1:3], c.collisions) for c in clients}
        assert finished, f"not every robot finished within {DRIVE_S} s: {report}"
        closest = closest_approach([c.truth for c in clients])
        print(f"swap took {session.time - t0:.1f} s of simulated time; closest approach {closest:.2f} m; {report}")
        # robot1 passed the others in the corridor (otherwise the test proves little): closer than 2 m.
        assert closest < 2.0, closest

        for client, goal, result in zip(clients, goals, results):
            name = client.get_namespace()
            standing, since = longest_standstill(client.truth, t0)
            print(f"{name}: longest standstill while driving {standing:.1f} s (from t = {since:.1f} s)")
            assert standing <= STANDING_LIMIT_S, f"{name} stood {standing:.1f} s from t = {since:.1f} s"
            assert result.result().status == 4, f"{name}: status {result.result().status}"  # SUCCEEDED
            _, x, y, _ = client.truth[-1]
            assert math.hypot(x - goal.x, y - goal.y) < 0.5, (name, x, y, goal)
            assert client.collisions == 0, f"{name} touched something {client.collisions} time(s)"
        for client in clients:
            session.driver.remove_node(client)
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

