"""Several robots from one launch: generate(args) launch files, namespaces and prefixed frames."""

import textwrap

import pytest

from simplebot_navigation.launch.loader import LaunchError, declared_args, load_launch


def by_name(config):
    return {node.full_name: node for node in config.nodes}


def test_robots_argument_gives_one_move_base_per_namespace():
    nodes = by_name(load_launch("multi_navigation", {"robots": "3", "starts": "0,0,0;2,0,0;4,0,0"}))
    assert sorted(nodes) == [f"/robot{i}/{node}" for i in (1, 2, 3) for node in ("collision_monitor", "move_base")] \
        + ["/simulator"]
    sim = nodes["/simulator"].parameters
    assert sim["namespaces"] == "robot1 robot2 robot3"
    assert sim["starts"] == "0,0,0;2,0,0;4,0,0"
    assert sorted(by_name(load_launch("multi_navigation", {"robots": "1"}))) == [
        "/robot1/collision_monitor", "/robot1/move_base", "/simulator"]


def test_each_move_base_gets_its_own_frames_and_topics():
    move_base = by_name(load_launch("multi_navigation", {"robots": "2"}))["/robot2/move_base"]
    params = move_base.parameters
    for costmap in ("global_costmap", "local_costmap"):
        assert params[f"{costmap}.global_frame"] == "robot2/odom"
        assert params[f"{costmap}.robot_base_frame"] == "robot2/base_link"
        assert params[f"{costmap}.obstacles.front_laser.sensor_frame"] == "robot2/front_laser_link"
        assert params[f"{costmap}.obstacles.back_laser.topic"] == "back_laser/back_scan"
    assert params["TebLocalPlannerROS.map_frame"] == "robot2/odom"
    # The rest of the lab's configuration is untouched.
    assert params["global_costmap.inflation_layer.inflation_radius"] == 1.5
    assert move_base.namespace == "/robot2"
    assert ("cmd_vel", "cmd_vel_nav") in move_base.remaps
    monitor = by_name(load_launch("multi_navigation", {"robots": "2"}))["/robot2/collision_monitor"]
    assert monitor.parameters["base_frame"] == "robot2/base_link" and monitor.namespace == "/robot2"


def test_single_robot_namespace_matches_the_multi_robot_one():
    single = by_name(load_launch("navigation", {"namespace": "robot1"}))
    multi = by_name(load_launch("multi_navigation", {"robots": "1"}))
    assert sorted(single) == ["/robot1/collision_monitor", "/robot1/move_base", "/simulator"]
    for node in ("/robot1/move_base", "/robot1/collision_monitor"):
        assert single[node].parameters == multi[node].parameters
    assert single["/simulator"].parameters["namespaces"] == "robot1"


def test_without_namespace_the_lab_frames_stay():
    params = by_name(load_launch("navigation"))["/move_base"].parameters
    assert params["global_costmap.global_frame"] == "/odom"
    assert params["global_costmap.obstacles.front_laser.sensor_frame"] == "/front_laser_link"
    assert params["global_costmap.obstacles.front_laser.topic"] == "/front_laser/front_scan"


@pytest.mark.parametrize("robots", ["0", "three", "-1"])
def test_bad_robot_count_is_named(robots):
    with pytest.raises(LaunchError, match=rf"multi_navigation.py: generate\(\): ValueError: robots:='{robots}' "
                                          "must be a whole number from 1 to max_robots"):
        load_launch("multi_navigation", {"robots": robots})


def test_generated_launch_file_rules(tmp_path):
    good = tmp_path / "repeat.py"
    good.write_text(textwrap.dedent("""
        from simplebot_navigation.launch.description import Arg, Node
        ARGS = [Arg("n", default="2")]
        def generate(args):
            return [Node(pkg="p", type="t", name=f"node{i}") for i in range(int(args["n"]))]
    """))
    assert [a.name for a in declared_args(str(good))] == ["n"]
    assert [n.name for n in load_launch(str(good), {"n": "3"}).nodes] == ["node0", "node1", "node2"]
    with pytest.raises(LaunchError, match="unknown argument"):
        load_launch(str(good), {"m": "1"})

    for name, body, message in [
        ("none.py", "X = 1", "defines neither a LAUNCH list nor ARGS and generate"),
        ("bad_args.py", "ARGS = ['n']\ndef generate(args): return []", "ARGS must be a list of Arg"),
        ("not_list.py", "def generate(args): return None", r"generate\(\) must return a list"),
    ]:
        path = tmp_path / name
        path.write_text(body)
        with pytest.raises(LaunchError, match=f"{name}: {message}"):
            load_launch(str(path))
