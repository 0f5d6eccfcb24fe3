"""NAME=VALUE overrides (--set) and run-time changes go through the same checks as the lab's files."""

import pytest

from simplebot_navigation.move_base.parameter_tree import apply_move_base_overrides, check_tree, parameter_table
from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.parameters.overrides import parse_assignment
from simplebot_navigation.testing.lab_params import navigation_tree


@pytest.fixture
def lab():
    """The lab's move_base tree, loaded as move_base_local.launch loads it."""
    return navigation_tree()


def _lab_warnings(tree):
    return [w for w in check_tree(tree) if "inf_is_valid" not in w and "Pre-Hydro" not in w]


def test_the_lab_tree_loads_without_unknown_or_unimplemented_parameters(lab):
    assert _lab_warnings(lab) == []


def test_overrides_set_checked_values_without_touching_the_given_tree(lab):
    tree, warnings = apply_move_base_overrides(lab, ["TebLocalPlannerROS.max_vel_x=0.6",
                                                     "local_costmap.inflation_layer.inflation_radius=0.3",
                                                     "global_costmap.obstacles.front_laser.obstacle_range=5",
                                                     "controller_frequency=10"])
    assert tree["TebLocalPlannerROS"]["max_vel_x"] == 0.6
    assert tree["local_costmap"]["inflation_layer"]["inflation_radius"] == 0.3
    assert tree["global_costmap"]["obstacles"]["front_laser"]["obstacle_range"] == 5.0
    assert tree["controller_frequency"] == 10.0 and isinstance(tree["controller_frequency"], float)
    assert lab["local_costmap"]["inflation_layer"]["inflation_radius"] == 1.5
    assert _lab_warnings(tree) == [] and len(warnings) == len(check_tree(lab))


@pytest.mark.parametrize("assignment, message", [
    ("TebLocalPlannerROS.max_vel_x=.nan", r"TebLocalPlannerROS.max_vel_x: expected a number \(finite\), got nan"),
    ("TebLocalPlannerROS.max_vel_x=fast", r"TebLocalPlannerROS.max_vel_x: expected a number, got 'fast'"),
    ("TebLocalPlannerROS.max_vel_x=-1", r"TebLocalPlannerROS.max_vel_x: must be in \(0, 2\], got -1.0"),
    ("TebLocalPlannerROS.max_samples=2", r"max_samples: must be >= min_samples \(3\)"),
    ("TebLocalPlannerROS.max_vel_xx=1", r"TebLocalPlannerROS.max_vel_xx: no such parameter; "
                                        r"did you mean 'TebLocalPlannerROS.max_vel_x'\?"),
    ("local_costmap.inflation_layer.inflation_radius=-0.3", r"inflation_radius: must be >= 0"),
    ("local_costmap.obstacles.side_laser.topic=x", r"local_costmap.obstacles.side_laser.topic: no such parameter"),
    ("TebLocalPlannerROS.footprint_model.front_radius=wide", r"footprint_model/front_radius"),
    ("max_vel_x", r"expected NAME=VALUE"),
    ("TebLocalPlannerROS.max_vel_x=", r"the value is empty"),
])
def test_bad_overrides_are_rejected_naming_the_parameter(lab, assignment, message):
    with pytest.raises(ParameterError, match=message):
        apply_move_base_overrides(lab, [assignment])


def test_an_override_without_effect_warns_once_naming_it(lab):
    _, warnings = apply_move_base_overrides(lab, ["TebLocalPlannerROS.weight_shortest_path=1.0"])
    assert len([w for w in warnings if "weight_shortest_path" in w]) == 1


def test_a_dict_valued_parameter_takes_overrides_below_it(lab):
    tree, _ = apply_move_base_overrides(lab, ["TebLocalPlannerROS.footprint_model.front_radius=0.25"])
    assert tree["TebLocalPlannerROS"]["footprint_model"]["front_radius"] == 0.25


def test_live_changes_refuse_parameters_that_need_a_restart(lab):
    apply_move_base_overrides(lab, [("TebLocalPlannerROS.max_vel_x", 0.2)], live=True)
    for name, value in (("local_costmap.global_frame", "map"), ("TebLocalPlannerROS.footprint_model", {}),
                        ("TebLocalPlannerROS.footprint_model.front_radius", 0.3), ("local_costmap.plugins", []),
                        ("local_costmap.obstacles.plugin", "costmap_2d::StaticLayer"), ("base_local_planner", "x/Y"),
                        ("local_costmap.resolution", 0.1), ("conservative_reset_dist", 2.0)):
        with pytest.raises(ParameterError, match=f"{name}: requires restart"):
            apply_move_base_overrides(lab, [(name, value)], live=True)


def test_live_changes_refuse_parameters_without_effect_but_overrides_take_them(lab):
    with pytest.raises(ParameterError, match="weight_shortest_path: not set to 1.0, since it has no effect here: "
                                             "the shortest-path edge is not added"):
        apply_move_base_overrides(lab, [("TebLocalPlannerROS.weight_shortest_path", 1.0)], live=True)
    apply_move_base_overrides(lab, [("TebLocalPlannerROS.weight_shortest_path", 1.0)])


def test_the_table_follows_the_tree(lab):
    table = parameter_table(lab)
    assert "local_costmap.obstacles.back_laser.raytrace_range" in table
    assert "GlobalPlanner.use_dijkstra" in table and "NavfnROS.visualize_potential" not in table
    assert "aggressive_reset.reset_distance" in table and "rotate_recovery.max_vel_theta" in table
    assert table["TebLocalPlannerROS.max_vel_x"].unit == "m/s"
    assert table["local_costmap.inflation_radius"] is table["local_costmap.inflation_layer.inflation_radius"]
    assert table["local_costmap.obstacle_range"].unit == "m"


def test_assignments_are_read_as_yaml():
    assert parse_assignment("a.b=0.6") == ("a.b", 0.6)
    assert parse_assignment("a.b = true") == ("a.b", True)
    assert parse_assignment("a.b=[[0.2, 0.1], [0, 1]]") == ("a.b", [[0.2, 0.1], [0, 1]])
    assert parse_assignment("a.b=odom") == ("a.b", "odom")


@pytest.mark.parametrize("args", [{}, {"tight": "true"}, {"robot": "round"}, {"tight": "true", "robot": "round"}])
def test_every_shipped_parameter_set_is_known_and_implemented(args):
    from simplebot_navigation.launch.loader import load_launch
    from simplebot_navigation.parameters.ros2 import from_ros2_overrides

    move_base = next(node for node in load_launch("navigation", args).nodes if node.name == "move_base")
    given = {k: v for k, v in move_base.parameters.items() if k != "use_sim_time"}
    warnings = check_tree(from_ros2_overrides(given))
    assert [w for w in warnings if "unknown parameter" in w or "no effect" in w] == []
