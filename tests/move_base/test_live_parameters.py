"""A running move_base's parameter changes, without ROS: checked as one change, taken once by the parts they
reach, refused whole with the reason when any part is wrong or would have no effect."""

import pytest

from simplebot_navigation.move_base.live_parameters import LiveParameters
from simplebot_navigation.parameters import ParameterError
from simplebot_navigation.testing.lab_params import navigation_tree


@pytest.fixture
def live():
    return LiveParameters(navigation_tree())


def test_an_accepted_change_is_taken_once_with_the_configurations_of_the_parts_it_reaches(live):
    live.change([("TebLocalPlannerROS.max_vel_x", 0.2)])
    live.change([("local_costmap.inflation_layer.inflation_radius", 0.5), ("conservative_reset.reset_distance", 2)])
    change = live.take()
    assert change.parts == {"local_planner", "local_costmap", "conservative_reset"}
    assert [name for name, _ in change.assignments] == ["TebLocalPlannerROS.max_vel_x",
                                                        "local_costmap.inflation_layer.inflation_radius",
                                                        "conservative_reset.reset_distance"]
    assert change.configs.local_planner.robot.max_vel_x == 0.2
    inflation = next(p for p in change.configs.costmaps["local_costmap"].plugins if p.name == "inflation_layer")
    assert inflation.params["inflation_radius"] == 0.5
    assert change.configs.recoveries["conservative_reset"]["reset_distance"] == 2.0
    assert live.take() is None


def test_a_move_base_parameter_reaches_the_costmaps_that_search_for_it(live):
    live.change([("controller_frequency", 10)])
    assert live.take().parts == {"move_base", "global_costmap", "local_costmap"}


def test_a_refused_change_changes_nothing(live):
    with pytest.raises(ParameterError, match=r"TebLocalPlannerROS.max_vel_theta: must be in \(0, 6\], got -1.0"):
        live.change([("TebLocalPlannerROS.max_vel_x", 0.2), ("TebLocalPlannerROS.max_vel_theta", -1.0)])
    assert live.take() is None
    assert live.configs.local_planner.robot.max_vel_x == 0.4 and "max_vel_x" not in live.tree["TebLocalPlannerROS"]


def test_a_value_another_parameter_overrides_is_refused_unless_that_one_changes_with_it(live):
    with pytest.raises(ParameterError, match=r"local_costmap.robot_radius: not set to 0.5, .*another parameter "
                                             r"takes precedence \(a footprint over robot_radius"):
        live.change([("local_costmap.robot_radius", 0.5)])
    live.change([("local_costmap.footprint", "[]"), ("local_costmap.robot_radius", 0.5)])
    assert live.take().configs.costmaps["local_costmap"].robot_radius == 0.5


def test_setting_the_value_a_parameter_has_is_accepted_and_changes_nothing(live):
    live.change([("TebLocalPlannerROS.max_vel_x", 0.4), ("GlobalPlanner.publish_potential", False)])
    assert live.take().configs.local_planner.robot.max_vel_x == 0.4


def test_values_are_normalized_to_what_the_parameter_holds(live):
    frequency = live.normalized("controller_frequency", 10)
    assert frequency == 10.0 and type(frequency) is float
    assert live.normalized("local_costmap.obstacles.combination_method", 0.0) == 0
    assert live.normalized("TebLocalPlannerROS.max_vel_x", "fast") == "fast"       # change() says why
    assert live.normalized("use_sim_time", True) is True


def test_obstacle_tracking_parameters_change_live_with_their_relations_checked(live):
    live.change([("obstacle_tracking.moving_speed", 0.4), ("obstacle_tracking.enabled", False)])
    change = live.take()
    assert change.parts == {"obstacle_tracking"}
    assert change.configs.obstacle_tracking.moving_speed == 0.4 and not change.configs.obstacle_tracking.enabled
    with pytest.raises(ParameterError, match="static_speed"):
        live.change([("obstacle_tracking.static_speed", 0.5)])
    with pytest.raises(ParameterError, match="association_gate"):
        live.change([("obstacle_tracking.association_gate", 0.0)])
    assert live.take() is None


def test_a_change_whose_parts_need_each_other_is_accepted_together(live):
    live.change([("obstacle_tracking.static_speed", 0.3), ("obstacle_tracking.moving_speed", 0.4)])
    assert live.take().configs.obstacle_tracking.static_speed == 0.3


def test_behavior_server_parameters_are_listed_and_change_live_within_their_ranges(live):
    assert {"behavior_server.simulate_ahead_time", "behavior_server.max_rotational_vel",
            "behavior_server.min_rotational_vel", "behavior_server.rotational_acc_lim"} <= set(live.table)
    assert live.table["behavior_server.max_rotational_vel"].describe() == "fastest turn of a Spin [rad/s] (in (0, 6])"
    assert live.configs.behavior_server.max_rotational_vel == 1.0
    live.change([("behavior_server.max_rotational_vel", 0.5), ("behavior_server.simulate_ahead_time", 1)])
    change = live.take()
    assert change.parts == {"behavior_server"}
    assert change.configs.behavior_server.max_rotational_vel == 0.5
    assert change.configs.behavior_server.simulate_ahead_time == 1.0
    with pytest.raises(ParameterError, match=r"behavior_server.rotational_acc_lim: must be in \(0, 50\], got -1.0"):
        live.change([("behavior_server.rotational_acc_lim", -1.0)])
    with pytest.raises(ParameterError, match=r"min_rotational_vel: must be at most max_rotational_vel \(0.5\)"):
        live.change([("behavior_server.min_rotational_vel", 0.6)])
    assert live.take() is None and live.configs.behavior_server.min_rotational_vel == 0.4
