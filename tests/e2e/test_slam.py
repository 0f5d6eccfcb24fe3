"""Mapping end to end in lockstep: navigation slam:=true maps the lab while move_base drives through it with drifting
encoders; the map is saved with slam/save_map and the session with slam/serialize_map, and the saved map then
serves navigation with map_server and amcl."""

import math

import pytest
from nav2_msgs.srv import LoadMap, SaveMap

from simplebot_navigation.maps.map_io import load_map
from simplebot_navigation.scenarios.runner import run_goal, time_budget
from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D
from simplebot_navigation.slam.session import session_path

pytestmark = [pytest.mark.e2e, pytest.mark.timeout(600)]

#: a tour of the lab's west half whose every goal lies within the lidars' reach of what the robot saw before: a
#: goal outside the map built so far is outside the global costmap, and move_base refuses it
TOUR = (Pose2D(-4.5, 0.0, math.pi, "corridor_west"), Pose2D(-7.5, 0.0, math.pi, "corridor_end"),
        Pose2D(-8.0, 4.5, 1.5708, "nw_office"), Pose2D(-2.5, 3.0, 0.0, "meeting_north"),
        Pose2D(-1.0, 0.0, 0.0, "corridor"))


def call(session, node, service_type, name, request):
    client = node.create_client(service_type, name)
    session.run_until(None, client.service_is_ready, wall_timeout_s=30)
    future = client.call_async(request)
    session.run_until(None, future.done, wall_timeout_s=60)
    return future.result()


@pytest.fixture(scope="module")
def mapped(tmp_path_factory):
    folder = tmp_path_factory.mktemp("slam")
    with NavigationSession("lab", seed=2, slam=True) as session:
        session.wait_ready(wall_timeout_s=120.0)
        slam = next(n for n in session.nodes if n.get_name() == "slam")
        results = [run_goal(session, goal, time_budget(session.world, session.pose(), goal, 0.4)) for goal in TOUR]
        odom, truth = session.sim.sim.odometry(), session.pose()
        saved = call(session, session.client, SaveMap, "slam/save_map", SaveMap.Request(map_url=str(folder / "lab")))
        serialized = call(session, session.client, SaveMap, "slam/serialize_map",
                          SaveMap.Request(map_url=str(folder / "lab")))
        unwritable = call(session, session.client, SaveMap, "slam/save_map",
                          SaveMap.Request(map_url="/proc/no/such/folder/lab"))
        corrupt = folder / "corrupt.posegraph.npz"
        corrupt.write_bytes(session_path(folder / "lab").read_bytes()[:200])
        loaded_corrupt = call(session, session.client, LoadMap, "slam/deserialize_map",
                              LoadMap.Request(map_url=str(corrupt)))
        yield {"results": results, "odometry": (odom.x, odom.y), "truth": (truth.x, truth.y), "folder": folder,
               "saved": saved.result, "serialized": serialized.result, "unwritable": unwritable.result,
               "corrupt": loaded_corrupt.result, "nodes": len(slam.mapper.scans), "alive": slam.mapper is not None}


def test_move_base_reaches_every_goal_in_the_map_being_built(mapped):
    for goal, result in zip(TOUR, mapped["results"]):
        assert result.success, (goal.name, result.failures)
        assert result.position_error < 0.25 and result.collisions == 0, goal.name
    # the odometry drifted by far more than that: the goals landed because the map frame is right
    drift = math.dist(mapped["odometry"], mapped["truth"])       # the lab's start is the origin, yaw 0
    assert drift > 0.5


def test_the_saved_map_is_the_lab(mapped):
    assert mapped["saved"] and mapped["serialized"]
    saved = load_map(mapped["folder"] / "lab.yaml")
    assert saved.resolution == pytest.approx(0.05)
    occupied = (saved.data == 100).sum()
    assert occupied > 1000 and (saved.data == 0).sum() > 10 * occupied
    assert session_path(mapped["folder"] / "lab").stat().st_size > 0


def test_bad_requests_fail_with_the_map_kept(mapped):
    assert not mapped["unwritable"]
    assert mapped["corrupt"] == LoadMap.Response.RESULT_INVALID_MAP_DATA
    assert mapped["alive"] and mapped["nodes"] > 20


def test_navigation_on_the_saved_map_with_amcl(mapped):
    with NavigationSession("lab", seed=3, map_name=str(mapped["folder"] / "lab.yaml")) as session:
        session.wait_ready(wall_timeout_s=120.0)
        goal = session.world.goal("nw_office")
        result = run_goal(session, goal, time_budget(session.world, session.pose(), goal, 0.4))
        assert result.success, result.failures
        assert result.position_error < 0.25 and result.collisions == 0
