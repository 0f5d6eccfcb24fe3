"""Three robots on one map, in lockstep in one process: multi_navigation map:=lab builds one map_server and an amcl per
robot. While the encoders drift, each robot's /robotK/amcl_pose stays on its own ground truth, and each amcl publishes
map -> robotK/odom, so a viewer in map shows every robot where it is. robot1 drives to a goal given in map through
its move_base; robot2 and robot3 drive arcs of their own, so an amcl that read another robot's scans or frames would
be pulled off its robot."""

import math

import pytest
from rclpy.time import Time

from simplebot_navigation.ros.tf import Buffer, TransformListener
from simplebot_navigation.scenarios.localization import errors_against_truth
from simplebot_navigation.scenarios.session import WARM_UP_S, NavigationSession, ScenarioClient
from simplebot_navigation.sim.world import Pose2D

pytestmark = [pytest.mark.e2e, pytest.mark.timeout(300)]
NAMESPACES = ("robot1", "robot2", "robot3")
#: robot1's goal in map: 1.2 m north of its start, in the open-plan office
GOAL = Pose2D(-5.0, -1.8, math.pi / 2)
#: robot2's and robot3's (v, omega) for DRIVE_S: a left and a right arc, clear of the walls from their starts
ARCS = ((0.25, 0.3), (0.3, -0.2))
DRIVE_S = 3.0
WALL_S = 120.0


def test_each_robots_amcl_localizes_it_on_the_shared_map():
    with NavigationSession("lab", launch_file="multi_navigation", map_name="lab") as session:
        names = [n.get_fully_qualified_name() for n in session.nodes if n.get_name() in ("map_server", "amcl")]
        assert names == ["/map_server"] + [f"/{ns}/amcl" for ns in NAMESPACES]
        clients = [ScenarioClient(session.context, ns) for ns in NAMESPACES]
        for client in clients:
            session.driver.add_node(client)
        tf = Buffer(node=clients[0])
        TransformListener(tf, clients[0])                  # its subscriptions fill tf
        move_base = session.move_base                       # robot1's, the first of the launch

        def ready():
            return (clients[0].action.server_is_ready() and move_base.global_costmap.is_current()
                    and move_base.local_costmap.is_current())
        session.run_until(WARM_UP_S, wall_timeout_s=WALL_S)
        assert session.run_until(None, ready, wall_timeout_s=WALL_S), "robot1's move_base never became ready"

        sent = clients[0].action.send_goal_async(session.goal_message(GOAL))
        end = session.time + DRIVE_S
        while session.time < end - 1e-9:
            for robot, (v, w) in enumerate(ARCS, start=1):
                session.sim.sim.set_cmd_vel(v, w, robot=robot)
            session.run_until(session.time + 0.1, wall_timeout_s=WALL_S)
        for robot in (1, 2):
            session.sim.sim.set_cmd_vel(0.0, 0.0, robot=robot)
        assert session.run_until(None, sent.done, wall_timeout_s=WALL_S) and sent.result().accepted
        result = sent.result().get_result_async()
        assert session.run_until(session.time + 20.0, result.done, wall_timeout_s=WALL_S), "robot1's goal did not end"
        assert result.result().status == 4, f"robot1's goal: status {result.result().status}"    # SUCCEEDED

        for robot, (namespace, client) in enumerate(zip(NAMESPACES, clients)):
            start, (_, x, y, _) = session.world.starts[robot], client.truth[-1]
            assert math.hypot(x - start.x, y - start.y) > 0.7, f"{namespace} hardly moved"
            position, heading = errors_against_truth(client.localized, client.truth)
            assert len(position) >= 5, f"{namespace}: {len(position)} amcl poses while it drove"
            assert position.max() < 0.1 and heading.max() < math.radians(3), (namespace, position.max(), heading.max())
            assert tf.can_transform("map", f"{namespace}/odom", Time()), f"no map -> {namespace}/odom from its amcl"
            seen = tf.lookup_transform("map", f"{namespace}/base_link", Time())
            assert math.hypot(seen.transform.translation.x - x, seen.transform.translation.y - y) < 0.1, namespace
            assert client.collisions == 0, namespace
        _, x, y, _ = clients[0].truth[-1]
        assert math.hypot(x - GOAL.x, y - GOAL.y) < 0.3
