"""rosparam/roslaunch semantics on the lab's own launch and config files."""

import textwrap

import pytest

from simplebot_navigation.launch.loader import LaunchError, load_launch
from simplebot_navigation.launch.rosparam import ParamError, ParamServer, from_ros2_overrides, load_yaml_file


@pytest.fixture(scope="module")
def lab():
    return load_launch("navigation")


def test_lab_files_build_the_ros1_tree(lab):
    p = lab.params
    assert p.get("/move_base/global_costmap/inflation_layer/inflation_radius") == 1.5
    assert p.get("/move_base/local_costmap/inflation_layer/cost_scaling_factor") == 8.0
    assert p.get("/move_base/local_costmap/resolution") == 0.05
    assert p.get("/move_base/global_costmap/resolution") == 0.2
    assert p.get("/move_base/global_costmap/global_frame") == "/odom"
    assert p.get("/move_base/global_costmap/obstacles/front_laser/topic") == "/front_laser/front_scan"
    assert p.get("/move_base/local_costmap/obstacles/observation_sources") == "front_laser back_laser"
    assert p.get("/move_base/base_global_planner") == "global_planner/GlobalPlanner"
    assert p.get("/move_base/TebLocalPlannerROS/footprint_model/type") == "two_circles"
    assert p.get("/move_base/GlobalPlanner/publish_potential") is False
    assert p.get("/use_sim_time") is True


def test_move_base_gets_ros2_overrides(lab):
    move_base = next(n for n in lab.nodes if n.name == "move_base")
    params = move_base.parameters
    assert params["global_costmap.inflation_layer.inflation_radius"] == 1.5
    assert params["local_costmap.footprint"] == "[[0.45, 0.3], [0.45, -0.3], [-0.45, -0.3], [-0.45, 0.3]]"
    assert params["global_costmap.plugins"] == ["obstacles", "inflation_layer"]
    assert params["global_costmap.obstacles.plugin"] == "costmap_2d::ObstacleLayer"
    assert params["local_costmap.inflation_layer.plugin"] == "costmap_2d::InflationLayer"
    assert params["use_sim_time"] is True
    # Relative targets: at the root they are /simplebot_controller/..., in a robot's namespace under it.
    assert move_base.namespace == "/"
    assert ("cmd_vel", "cmd_vel_nav") in move_base.remaps            # to the collision monitor
    assert ("/odom", "simplebot_controller/odom") in move_base.remaps


def test_ros2_overrides_round_trip_to_the_ros1_tree(lab):
    move_base = next(n for n in lab.nodes if n.name == "move_base")
    tree = from_ros2_overrides(move_base.parameters)
    assert tree["global_costmap"]["plugins"] == [
        {"name": "obstacles", "type": "costmap_2d::ObstacleLayer"},
        {"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}]
    assert tree["local_costmap"]["obstacles"]["back_laser"]["inf_is_valid"] is True


def test_round_robot_overrides_are_loaded_after_the_lab_files():
    config = load_launch("navigation", {"robot": "round"})
    p = config.params
    assert p.get("/move_base/global_costmap/footprint") == []
    assert p.get("/move_base/local_costmap/robot_radius") == 0.3
    assert p.get("/move_base/TebLocalPlannerROS/footprint_model/type") == "circular"
    # untouched leaves of the lab's files survive the merge
    assert p.get("/move_base/TebLocalPlannerROS/odom_topic") == "/odom"
    assert p.get("/move_base/local_costmap/inflation_layer/inflation_radius") == 1.5


def test_the_round_body_radius_reaches_both_costmaps_and_teb():
    p = load_launch("navigation", {"robot": "round", "radius": "0.25", "tight": "true"}).params
    assert p.get("/simulator/radius") == 0.25
    assert p.get("/move_base/global_costmap/robot_radius") == 0.25
    assert p.get("/move_base/local_costmap/robot_radius") == 0.25
    assert p.get("/move_base/TebLocalPlannerROS/footprint_model/radius") == 0.25
    robots = load_launch("multi_navigation", {"robots": "2", "robot": "round", "radius": "0.25"}).params
    assert robots.get("/robot2/move_base/local_costmap/robot_radius") == 0.25
    box = load_launch("navigation", {"radius": "0.25"}).params    # the box keeps its outline
    assert len(box.get("/move_base/local_costmap/footprint")) == 4
    with pytest.raises(KeyError):
        box.get("/move_base/local_costmap/robot_radius")


def test_max_speed_reaches_the_simulator():
    assert load_launch("navigation", {}).params.get("/simulator/max_speed") == ""   # the lab's drive
    assert load_launch("navigation", {"robot": "round", "max_speed": "2.0"}).params.get("/simulator/max_speed") == 2.0
    robots = load_launch("multi_navigation", {"robots": "2", "robot": "round", "max_speed": "1.5"}).params
    assert robots.get("/simulator/max_speed") == 1.5


def test_tight_set_goes_under_the_round_body():
    box = load_launch("navigation", {"tight": "true"}).params
    assert box.get("/move_base/global_costmap/resolution") == 0.05
    assert box.get("/move_base/local_costmap/resolution") == 0.025
    assert box.get("/move_base/local_costmap/footprint_padding") == 0.0
    assert box.get("/move_base/TebLocalPlannerROS/footprint_model/type") == "polygon"
    assert box.get("/move_base/TebLocalPlannerROS/min_obstacle_dist") == 0.03
    assert box.get("/move_base/TebLocalPlannerROS/global_plan_viapoint_sep") == 0.1     # the box swings out
    round_body = load_launch("navigation", {"tight": "true", "robot": "round"}).params
    assert round_body.get("/move_base/TebLocalPlannerROS/footprint_model/type") == "circular"
    assert round_body.get("/move_base/TebLocalPlannerROS/global_plan_viapoint_sep") < 0  # it turns on the spot
    assert round_body.get("/move_base/global_costmap/resolution") == 0.05
    assert round_body.get("/move_base/local_costmap/footprint_padding") == 0.0      # the tight set's, not round's
    assert round_body.get("/move_base/local_costmap/footprint") == []
    assert load_launch("navigation", {"robot": "round"}).params.get("/move_base/local_costmap/footprint_padding") == 0.02
    assert load_launch("navigation", {}).params.get("/move_base/global_costmap/resolution") == 0.2


def test_later_load_merges_leaves():
    server = ParamServer()
    server.set("/a", {"b": {"c": 1, "d": [1, 2]}})
    server.set("/a", {"b": {"c": 2}})
    assert server.get("/a/b") == {"c": 2, "d": [1, 2]}


def test_unknown_arg_and_bad_choice_are_named():
    with pytest.raises(LaunchError, match="robot='tank' is not one of box, round"):
        load_launch("navigation", {"robot": "tank"})
    with pytest.raises(LaunchError, match="unknown argument.*speed"):
        load_launch("navigation", {"speed": "3"})


def test_malformed_yaml_names_file_and_line(tmp_path):
    bad = tmp_path / "broken.yaml"
    bad.write_text("obstacles:\n  front_laser: {data_type: LaserScan,\n  topic: [\n")
    with pytest.raises(ParamError) as err:
        load_yaml_file(str(bad))
    assert str(bad) in str(err.value) and "malformed YAML at line" in str(err.value)


@pytest.mark.parametrize("text, fragment", [
    ("1: 2\n", "key 1 is a int"),
    ("obstacles:\n  sources:\n", "obstacles/sources: empty value"),
    ("when: 2024-01-01\n", "when: value datetime.date"),
    ("- a\n- b\n", "top level must be a mapping"),
])
def test_bad_key_or_value_types_are_named(tmp_path, text, fragment):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    with pytest.raises(ParamError) as err:
        load_yaml_file(str(path))
    assert str(path) in str(err.value) and fragment in str(err.value)


def test_missing_file_in_a_launch_file_is_named(tmp_path):
    launch = tmp_path / "broken_launch.py"
    launch.write_text(textwrap.dedent("""
        from simplebot_navigation.launch.description import Node, RosParam
        LAUNCH = [Node(pkg="python", type="tests.launch.dummy_node", name="n",
                       params=[RosParam(file="/nonexistent/costmap.yaml")])]
    """))
    with pytest.raises(LaunchError, match="/nonexistent/costmap.yaml: cannot read parameter file"):
        load_launch(str(launch))


def test_mixed_type_list_is_rejected_with_its_key(tmp_path):
    launch = tmp_path / "mixed_launch.py"
    launch.write_text(textwrap.dedent("""
        from simplebot_navigation.launch.description import Node, Param
        LAUNCH = [Node(pkg="python", type="tests.launch.dummy_node", name="n",
                       params=[Param("values", [1, "two"])])]
    """))
    with pytest.raises(LaunchError, match="/n/values: a list must hold values of one type"):
        load_launch(str(launch))
