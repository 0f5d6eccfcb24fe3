"""map_server and map_saver over real topics: the map latched for late subscribers, GetMap, a saved map that loads
back the same, a bad file at start (exit 2, one line naming the YAML file and the key) and the same file set live
(refused, the old map stays)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from nav_msgs.msg import MapMetaData, OccupancyGrid
from nav_msgs.srv import GetMap
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.qos import QoSProfile, ReliabilityPolicy

from simplebot_navigation.launch.nodes import resolve_executable
from simplebot_navigation.maps import load_map, save_map
from simplebot_navigation.ros.conversions import occupancy_map_from_msg
from simplebot_navigation.ros.executor import LeanExecutor
from simplebot_navigation.ros.map_saver_node import parse_arguments
from simplebot_navigation.ros.map_server_node import LATCHED, WORLD_MAP_RESOLUTION, MapServerNode, file_argument, read_map
from simplebot_navigation.sim import load_world
from simplebot_navigation.sim.map_export import export_map

pytestmark = pytest.mark.timeout(120)
REPO = Path(__file__).resolve().parents[2]
WAIT_S = 15.0


#: bad maps: YAML file -> (its image, the image's bytes or None for none, the key named, the problem stated)
BAD_MAPS = {
    "bad.yaml": ("office.pgm", None, "resolution", "must be positive, got -0.1"),
    "no_image.yaml": ("none.pgm", None, "image", "no such file"),
    "bad_mode.yaml": ("office.pgm", None, "mode", "expected trinary, scale or raw, got 'fancy'"),
    "truncated.yaml": ("truncated.pgm", b"P5\n20 20\n255\n" + bytes(10), "image",
                       "truncated.pgm: PGM has fewer than 20 x 20 pixels (truncated)"),
    "garbage.yaml": ("garbage.pgm", b"P5\n" + bytes(range(256)) * 4, "image",
                     "garbage.pgm: garbage PGM header: width b'\\x00\\x01"),
    "huge.yaml": ("huge.pgm", b"P5\n50000 50000\n255\n" + bytes(100), "image",
                  "huge.pgm: image is 50000 x 50000 pixels"),
    "big.yaml": ("big.pgm", b"P5\n2001 2000\n255\n" + bytes(100), "image",
                 "big.pgm: image is 2001 x 2000 pixels; a map has 1 to 16384 a side and at most 4000000 cells"),
}


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """The lab exported exactly and noisily, and the BAD_MAPS."""
    folder = tmp_path_factory.mktemp("maps")
    lab = load_world("lab")
    save_map(export_map(lab, 0.1), folder / "office.yaml")
    save_map(export_map(lab, 0.1, noisy_seed=1), folder / "noisy.yaml")
    for name, (image, content, _, _) in BAD_MAPS.items():
        if content is not None:
            (folder / image).write_bytes(content)
        resolution = -0.1 if name == "bad.yaml" else 0.1
        mode = "fancy" if name == "bad_mode.yaml" else "trinary"
        (folder / name).write_text(f"image: {image}\nresolution: {resolution}\norigin: [0, 0, 0]\nmode: {mode}\n")
    return folder


class Graph:
    """The map server and the nodes that talk to it, on one executor; all destroyed at the end of the test."""

    def __init__(self, context):
        self.context = context
        self.executor = LeanExecutor(context=context)
        self.nodes = []

    def add(self, node):
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def server(self, yaml_filename, **params):
        return self.add(MapServerNode(context=self.context, parameter_overrides=[
            Parameter("yaml_filename", value=str(yaml_filename)),
            *(Parameter(name, value=value) for name, value in params.items())]))

    def client(self, name):
        return self.add(rclpy.create_node(name, context=self.context))

    def spin_until(self, done, seconds=WAIT_S):
        deadline = time.monotonic() + seconds
        while not done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return done()

    def call(self, client, request):
        assert self.spin_until(client.service_is_ready), f"no {client.srv_name} service"
        future = client.call_async(request)
        assert self.spin_until(future.done)
        return future.result()


@pytest.fixture
def graph(context):
    graph = Graph(context)
    yield graph
    graph.executor.shutdown()
    for node in graph.nodes:
        node.destroy_node()


def subscribe(node, msg_type, topic, qos=LATCHED):
    received = []
    node.create_subscription(msg_type, topic, received.append, qos)
    return received


def test_a_late_subscriber_gets_the_latched_map_and_a_volatile_one_does_not(graph, maps):
    graph.server(maps / "office.yaml")
    graph.spin_until(lambda: False, seconds=0.2)                 # published well before anyone listens
    late = graph.client("late_listener")
    grids, metadata = subscribe(late, OccupancyGrid, "/map"), subscribe(late, MapMetaData, "/map_metadata")
    volatile = subscribe(late, OccupancyGrid, "/map", QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
    assert graph.spin_until(lambda: grids and metadata)
    expected = load_map(maps / "office.yaml")
    received = occupancy_map_from_msg(grids[0])
    assert np.array_equal(received.data, expected.data)
    assert received.frame_id == "map" and received.resolution == expected.resolution
    assert received.origin == pytest.approx(expected.origin)
    assert metadata[0] == grids[0].info
    graph.spin_until(lambda: False, seconds=0.3)
    assert not volatile


def test_get_map_returns_the_published_grid(graph, maps):
    graph.server(maps / "office.yaml", frame_id="/world")
    client = graph.client("get_map_client")
    grids = subscribe(client, OccupancyGrid, "/map")
    response = graph.call(client.create_client(GetMap, "/map_server/map"), GetMap.Request())
    assert graph.spin_until(lambda: grids)
    assert response.map == grids[0] and response.map.header.frame_id == "world"
    assert np.array_equal(occupancy_map_from_msg(response.map).data, load_map(maps / "office.yaml").data)


def test_a_world_name_serves_that_worlds_exported_map(graph):
    graph.server("lab")
    client = graph.client("world_map_client")
    grids = subscribe(client, OccupancyGrid, "/map")
    assert graph.spin_until(lambda: grids)
    expected = export_map(load_world("lab"), WORLD_MAP_RESOLUTION)
    assert np.array_equal(occupancy_map_from_msg(grids[0]).data, expected.data)
    with pytest.raises(ValueError, match="'atlantis' is neither a map YAML file nor a world"):
        read_map("atlantis")


def test_map_saver_writes_a_map_that_loads_back_the_same(graph, maps, tmp_path):
    graph.server(maps / "noisy.yaml")
    saver = subprocess.Popen([sys.executable, "-m", "simplebot_navigation.ros.map_saver_node", "-f",
                              str(tmp_path / "saved"), "--timeout", str(WAIT_S)],
                             cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        graph.spin_until(lambda: saver.poll() is not None, seconds=2 * WAIT_S)
    finally:
        if saver.poll() is None:
            saver.kill()
        out, err = saver.communicate()
    assert saver.returncode == 0, err
    assert "wrote" in out and "saved.pgm" in out
    original, saved = load_map(maps / "noisy.yaml"), load_map(tmp_path / "saved.yaml")
    assert np.array_equal(saved.data, original.data)
    assert saved.resolution == original.resolution and saved.origin == pytest.approx(original.origin)


@pytest.mark.parametrize("name", BAD_MAPS)
def test_map_server_exits_2_with_one_line_naming_the_file_and_the_key(maps, name):
    _, _, key, problem = BAD_MAPS[name]
    result = subprocess.run([sys.executable, "-m", "simplebot_navigation.ros.map_server_node", str(maps / name)],
                            cwd=REPO, capture_output=True, text=True, timeout=WAIT_S * 2)
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1, result.stderr                   # one line, no traceback
    assert result.stderr.startswith(f"map_server: {maps / name}: {key}: ") and problem in result.stderr


def test_a_bad_file_set_live_is_refused_and_the_old_map_stays(graph, maps):
    graph.server(maps / "office.yaml")
    client = graph.client("parameter_client")
    grids = subscribe(client, OccupancyGrid, "/map")
    set_service = client.create_client(SetParameters, "/map_server/set_parameters")

    def set_file(path):
        request = SetParameters.Request(parameters=[Parameter("yaml_filename", value=str(path)).to_parameter_msg()])
        return graph.call(set_service, request).results[0]

    def current_file():
        request = GetParameters.Request(names=["yaml_filename"])
        values = graph.call(client.create_client(GetParameters, "/map_server/get_parameters"), request).values
        return parameter_value_to_python(values[0])

    assert graph.spin_until(lambda: grids)
    refusals = {name: (f"{maps / name}: {key}: ", problem) for name, (_, _, key, problem) in BAD_MAPS.items()}
    for name, (prefix, problem) in {**refusals, "missing.yaml": (f"{maps / 'missing.yaml'}: ", "no such file")}.items():
        result = set_file(maps / name)
        assert not result.successful and result.reason.startswith(prefix) and problem in result.reason, result.reason
    assert current_file() == str(maps / "office.yaml")
    late = graph.client("late_listener")
    late_grids = subscribe(late, OccupancyGrid, "/map")
    assert graph.spin_until(lambda: late_grids)
    office = load_map(maps / "office.yaml").data
    assert len(grids) == 1 and np.array_equal(occupancy_map_from_msg(late_grids[0]).data, office)

    assert set_file(maps / "noisy.yaml").successful                 # a good file is taken, and published
    assert graph.spin_until(lambda: len(grids) == 2)
    assert np.array_equal(occupancy_map_from_msg(grids[1]).data, load_map(maps / "noisy.yaml").data)
    assert current_file() == str(maps / "noisy.yaml")


def test_the_file_comes_from_the_first_argument_and_both_executables_are_registered():
    (given,) = file_argument(["map_server", "office.yaml", "--ros-args", "-p", "frame_id:=map"])
    assert (given.name, given.value) == ("yaml_filename", "office.yaml")
    assert file_argument(["map_server", "--ros-args", "-p", "yaml_filename:=office.yaml"]) == []
    with pytest.raises(ValueError, match="one map YAML file at most"):
        file_argument(["map_server", "a.yaml", "b.yaml"])
    assert resolve_executable("map_server", "map_server").node_class == "MapServerNode"
    assert resolve_executable("map_server", "map_saver").module == "simplebot_navigation.ros.map_saver_node"


def test_map_saver_without_a_map_exits_1_with_one_line(tmp_path):
    result = subprocess.run([sys.executable, "-m", "simplebot_navigation.ros.map_saver_node", "-f",
                             str(tmp_path / "saved"), "--timeout", "0.5", "--map-topic", "no_map_here"],
                            cwd=REPO, capture_output=True, text=True, timeout=WAIT_S * 2)
    assert result.returncode == 1
    assert result.stderr.strip() == "map_saver: no map on 'no_map_here' within 0.5 s"
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("args, message", [
    (["--occ", "1.5"], "--occ: must be in [0, 1], got 1.5"),
    (["--occ", "0.2", "--free", "0.3"], "--free: 0.3 must be below occupied_thresh 0.2"),
    (["--mode", "fancy"], "argument --mode: invalid choice: 'fancy'"),
    (["--timeout", "0"], "--timeout: must be a positive number of seconds"),
    (["-f", "/no/such/folder/office"], "folder /no/such/folder does not exist"),
])
def test_map_saver_refuses_bad_arguments_in_one_line(capsys, args, message):
    with pytest.raises(SystemExit) as exit:
        parse_arguments(args)
    err = capsys.readouterr().err
    assert exit.value.code == 2 and message in err and err.count("\n") == 1, err


def test_a_burst_of_50_get_map_requests_is_answered_in_full(graph, maps):
    graph.server(maps / "office.yaml")
    client = graph.client("burst_client").create_client(GetMap, "/map_server/map")
    assert graph.spin_until(client.service_is_ready)
    futures = [client.call_async(GetMap.Request()) for _ in range(50)]
    graph.spin_until(lambda: all(f.done() for f in futures), seconds=30.0)
    assert sum(f.done() for f in futures) == 50
