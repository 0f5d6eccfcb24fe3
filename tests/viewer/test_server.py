"""The viewer's data path without a browser: costmap downsampling, frames over HTTP, goals by POST."""

import json
import math
import time
import urllib.error
import urllib.request

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.parameter import Parameter

from simplebot_navigation.move_base.events import MoveBaseEvents
from simplebot_navigation.ros.conversions import yaw_of
from simplebot_navigation.ros.move_base.move_base_stats import navigation_status
from simplebot_navigation.viewer.node import PARAMETERS, ViewerNode, body_outlines
from simplebot_navigation.viewer.scene import UNKNOWN_CELL, Scene, downsample_grid
from simplebot_description import robot_description
from tests.viewer.conftest import CART_SIZE, CART_Y, LETHAL_BLOCK, ORIGIN, RESOLUTION, cells


def decode(frame: bytes):
    """The page's decoding (viewer.js decode) in Python."""
    length = int.from_bytes(frame[:4], "little")
    header = json.loads(frame[4:4 + length])
    base = (4 + length + 7) // 8 * 8
    arrays = [np.frombuffer(frame, dtype=np.uint8 if b["type"] == "u8" else np.float32,
                            count=b["bytes"] // (1 if b["type"] == "u8" else 4), offset=base + b["offset"])
              for b in header["buffers"]]
    return header, arrays


def get(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=5) as response:
        return response.read()


def post_goal(url: str, body: bytes, path: str = "goal"):
    request = urllib.request.Request(url + path, data=body, method="POST",
                                     headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=5) as response:
            return response.status, response.read().decode()
    except urllib.error.HTTPError as err:
        return err.code, err.read().decode()


def test_downsampling_keeps_the_highest_known_cost():
    grid = np.zeros((600, 1000), dtype=np.int8)
    grid[301, 502] = 100            # one lethal cell
    grid[:30, :30] = -1             # unknown blocks
    grid[0:3, 30:33] = -1
    grid[0, 32] = 0                 # one known free cell in an otherwise unknown block
    out, factor = downsample_grid(grid, 400)
    assert factor == 3 and out.shape == (200, 334)
    assert out[100, 167] == 100 and np.count_nonzero(out == 100) == 1
    assert (out[:10, :10] == UNKNOWN_CELL).all()
    assert out[0, 10] == 0
    same, one = downsample_grid(grid[:200, :300], 400)
    assert one == 1 and np.array_equal(same, np.where(grid[:200, :300] < 0, 255, grid[:200, :300].astype(int)))


def test_costmap_updates_outside_the_grid_are_refused():
    scene = Scene()
    with pytest.raises(ValueError, match="update arrived before any full costmap"):
        scene.update_grid("local_costmap", 0, 0, np.zeros((2, 2), np.int8))
    scene.set_grid("local_costmap", np.zeros((10, 20), np.int8), 0.05, (0.0, 0.0, 0.0), "odom")
    scene.update_grid("local_costmap", 18, 8, np.full((2, 2), 100, np.int8))
    assert scene.grids["local_costmap"].cells[8:, 18:].tolist() == [[100, 100], [100, 100]]
    with pytest.raises(ValueError, match="x=19 y=8 2x2 lies outside the 20x10 grid"):
        scene.update_grid("local_costmap", 19, 8, np.zeros((2, 2), np.int8))


def test_body_outlines_of_the_lab_robot():
    outlines = body_outlines(robot_description("box").urdf)
    chassis = max(outlines, key=lambda o: np.ptp(o[:, 0]) * np.ptp(o[:, 1]))
    assert np.ptp(chassis[:, 0]) == pytest.approx(0.9) and np.ptp(chassis[:, 1]) == pytest.approx(0.6)
    round_body = body_outlines(robot_description("round", 0.4).urdf)
    disc = max(round_body, key=lambda o: np.ptp(o[:, 0]))
    assert np.hypot(disc[:, 0], disc[:, 1]) == pytest.approx(0.4)


def test_frames_carry_the_costmap_once_and_the_scans_in_odom(scenario):
    url = scenario.viewer.url
    get(url + "frame?after=-1")  # a page is open: the viewer subscribes
    frames = []

    def drawable():  # the scan needs its transform too, which may arrive after the first scan
        frames.append(decode(get(url + "frame?after=-1")))
        header = frames[-1][0]
        return "global_costmap" in header["costmaps"] and "front_scan" in header["layers"]

    scenario.wait_for(drawable, what="costmap and scans in a frame")
    header, arrays = frames[-1]
    grid = header["costmaps"]["global_costmap"]
    # OccupancyGrid carries the resolution as float32
    assert (grid["width"], grid["height"], grid["resolution"]) == (200, 200, float(np.float32(RESOLUTION)))
    assert grid["origin"] == [ORIGIN[0], ORIGIN[1], 0.0]
    image = arrays[grid["buffer"]].reshape(200, 200)
    assert (image[cells(LETHAL_BLOCK)] == 100).all() and np.count_nonzero(image == 100) == 100
    front = arrays[header["layers"]["front_scan"]["buffer"]].reshape(-1, 2)
    assert front[:, 0].max() == pytest.approx(2.2, abs=0.02)  # the wall ahead, in odom
    assert header["robot"] == pytest.approx([0.0, 0.0, 0.0], abs=0.01)
    # A page that holds this costmap version gets the frame without it.
    again, _ = decode(get(url + f"frame?after={header['version']}&global_costmap={grid['version']}"))
    assert "buffer" not in again["costmaps"]["global_costmap"]
    assert again["version"] > header["version"]


def test_moving_obstacles_are_drawn_as_outlines_in_odom(scenario):
    url = scenario.viewer.url
    get(url + "frame?after=-1")
    frames = []

    def drawable():
        frames.append(decode(get(url + "frame?after=-1")))
        return "moving_obstacles" in frames[-1][0]["layers"]

    scenario.wait_for(drawable, what="the moving obstacles in a frame")
    header, arrays = frames[-1]
    layer = header["layers"]["moving_obstacles"]
    outline = arrays[layer["buffer"]].reshape(-1, 2)
    assert layer["stride"] == 2 and outline.shape == (6, 2) and np.isnan(outline[-1]).all()
    xs, ys = outline[:-1, 0], outline[:-1, 1]
    assert xs.max() - xs.min() == pytest.approx(CART_SIZE[0], abs=1e-5)
    assert ys.min() == pytest.approx(CART_Y - CART_SIZE[1] / 2, abs=1e-5)
    assert -1.2 <= xs.min() <= 1.0


def test_static_page_and_unknown_paths(scenario):
    page = get(scenario.viewer.url)
    assert b"2D Nav Goal" in page and b"2D Pose Estimate" in page
    assert b"worldToPage" in get(scenario.viewer.url + "viewer.js")
    with pytest.raises(urllib.error.HTTPError, match="404"):
        get(scenario.viewer.url + "nothing")


def test_goal_post_is_checked_and_published(scenario):
    url = scenario.viewer.url
    assert post_goal(url, b'{"x": "one", "y": 0, "yaw": 0}') == (400, "goal: 'x' must be a finite number, got 'one'")
    assert post_goal(url, b'{"x": 1, "y": NaN, "yaw": 0}') == (400, "goal: 'y' must be a finite number, got nan")
    assert post_goal(url, b"[1, 2, 3]")[0] == 400
    before = len(scenario.move_base.goals)
    status, body = post_goal(url, b'{"x": -1.25, "y": 0.5, "yaw": -2.0}')
    assert status == 200 and json.loads(body) == {"x": -1.25, "y": 0.5, "yaw": -2.0}
    scenario.wait_for(lambda: len(scenario.move_base.goals) > before, what="the goal")
    goal = scenario.move_base.goals[-1]
    assert (goal.header.frame_id, goal.pose.position.x, goal.pose.position.y) == ("odom", -1.25, 0.5)
    assert yaw_of(goal.pose.orientation) == pytest.approx(-2.0, abs=1e-12)
    assert not math.isnan(goal.pose.orientation.w)


def test_pose_estimate_post_is_checked_and_published_with_rviz_spread(scenario):
    url = scenario.viewer.url
    assert post_goal(url, b'{"x": 1, "y": 1e999, "yaw": 0}', "initialpose") == (
        400, "initialpose: 'y' must be a finite number, got inf")
    status, _ = post_goal(url, b'{"x": 2.5, "y": -1.0, "yaw": 1.5}', "initialpose")
    assert status == 200
    scenario.wait_for(lambda: scenario.move_base.initial_poses, what="the initial pose")
    pose = scenario.move_base.initial_poses[-1]
    assert (pose.header.frame_id, pose.pose.pose.position.x, pose.pose.pose.position.y) == ("odom", 2.5, -1.0)
    assert yaw_of(pose.pose.pose.orientation) == pytest.approx(1.5, abs=1e-12)
    covariance = np.array(pose.pose.covariance).reshape(6, 6)
    assert np.diag(covariance)[[0, 1, 5]] == pytest.approx([0.25, 0.25, (math.pi / 12) ** 2])
    assert not scenario.move_base.goals or scenario.move_base.goals[-1].pose.position.x != 2.5
    assert post_goal(url, b'{"x": 0, "y": 0, "yaw": 0}', "elsewhere")[0] == 404


def test_a_taken_port_is_named(scenario, context):
    port = int(scenario.viewer.url.rsplit(":", 1)[1].strip("/"))
    with pytest.raises(OSError, match=f"viewer cannot listen on 127.0.0.1:{port}: .*set the 'port' parameter"):
        ViewerNode(context=context, parameter_overrides=[Parameter("port", value=port)])
    with pytest.raises(ValueError, match=r"viewer parameter 'rate': must be in \[0.1, 60\], got 0.0"):
        ViewerNode(context=context, parameter_overrides=[Parameter("rate", value=0.0)])
    with pytest.raises(ValueError, match=r"viewer parameter 'trail_points': must be in \[2, 100000\], got 1000000000"):
        ViewerNode(context=context, parameter_overrides=[Parameter("trail_points", value=10**9)])
    with pytest.raises(ValueError, match="viewer parameter 'fixed_frame': expected a frame name, got '/'"):
        ViewerNode(context=context, parameter_overrides=[Parameter("fixed_frame", value="/")])


@pytest.mark.parametrize("name, value, said", [
    ("rate", 1e308, "1e+308"),
    ("rate", 1e-300, "1e-300"),
    ("costmap_rate", math.nan, "nan"),
    ("max_costmap_side", 10**6, "1000000"),
    ("trail_points", "many", "'many'"),
    ("port", 9000, "requires restart"),
    ("fixed_frame", "map", "requires restart"),
])
def test_live_changes_out_of_bounds_are_refused_with_the_reason(scenario, name, value, said):
    viewer = scenario.viewer
    before = (viewer.server.period_s, viewer.scene.costmap_period_s, viewer.scene.max_costmap_side)
    result = viewer.set_parameters([Parameter(name, value=value)])[0]
    assert not result.successful and name in result.reason and said in result.reason, result.reason
    assert (viewer.server.period_s, viewer.scene.costmap_period_s, viewer.scene.max_costmap_side) == before


def test_live_rates_and_sizes_are_taken(scenario):
    viewer = scenario.viewer
    try:
        assert all(r.successful for r in viewer.set_parameters([
            Parameter("rate", value=10), Parameter("costmap_rate", value=2.0), Parameter("trail_points", value=50)]))
        assert (viewer.server.period_s, viewer.scene.costmap_period_s, viewer.scene.trail_points) == (0.1, 0.5, 50)
    finally:
        viewer.set_parameters([Parameter(name, value=PARAMETERS[name].default)
                               for name in ("rate", "costmap_rate", "trail_points")])


def test_topics_are_taken_only_while_a_page_is_open(scenario, monkeypatch):
    viewer, scans = scenario.viewer, scenario.sim.robots[0].scan_pubs["front_laser_link"]
    get(viewer.url + "frame?after=-1")
    scenario.wait_for(lambda: viewer.watched and scans.get_subscription_count() == 1, what="the viewer to subscribe")
    monkeypatch.setattr("simplebot_navigation.viewer.node.PAGE_GONE_S", 0.5)
    scenario.wait_for(lambda: not viewer.watched and scans.get_subscription_count() == 0,
                      what="the viewer to let go of the topics")
    monkeypatch.setattr("simplebot_navigation.viewer.node.PAGE_GONE_S", 10.0)
    header, _ = decode(get(viewer.url + "frame?after=-1"))  # the page comes back: last data at once, then live
    assert "global_costmap" in header["costmaps"]
    scenario.wait_for(lambda: viewer.watched and scans.get_subscription_count() == 1, what="the viewer to subscribe")


def test_recoveries_come_from_move_base_diagnostics(scenario):
    url = scenario.viewer.url
    get(url + "frame?after=-1")
    scenario.wait_for(lambda: scenario.viewer.watched, what="the viewer to subscribe")
    logger = scenario.move_base.get_logger()
    warning = "Rotate recovery can't rotate in place because there is a potential collision"

    def warned():  # /rosout has just been subscribed: repeat until the link is up
        if any(line["text"] == warning for line in scenario.viewer.scene.log):
            return True
        logger.warn(warning)
        time.sleep(0.1)
        return False

    scenario.wait_for(warned, what="the viewer's /rosout subscription")
    logger.info("executing recovery behavior rotate_recovery (2/4) after CONTROLLING_R")
    scenario.wait_for(lambda: scenario.viewer.scene.log[-1]["level"] == "INFO", what="the info line")
    assert scenario.viewer.scene.recoveries["count"] == 0     # log text is not what counts
    events = MoveBaseEvents()
    events.recovery(1.0, "rotate_recovery", "rotate_recovery (2/4) after CONTROLLING_R")
    diagnostics = scenario.move_base.create_publisher(DiagnosticArray, "/diagnostics", 10)

    def counted():
        diagnostics.publish(DiagnosticArray(status=[navigation_status(events.snapshot(), "move_base")]))
        time.sleep(0.1)
        return scenario.viewer.scene.recoveries["count"] == 1

    scenario.wait_for(counted, what="the recovery count from /diagnostics")
    header, _ = decode(get(url + "frame?after=-1"))
    assert header["recoveries"] == {"count": 1, "last": "rotate_recovery (2/4) after CONTROLLING_R"}
    assert [line["level"] for line in header["log"][-2:]] == ["WARN", "INFO"]
