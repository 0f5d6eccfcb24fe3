"""The explore node's live parameters (ros2 param set): a change is checked against its spec, then used at once;
a bad value, a restart-only one or a name the node does not have is refused with the reason, and nothing changes.
No robot or map is needed: the node is built in the test's context and its parameters set as ros2 param set does."""

from __future__ import annotations

import pytest
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter

from simplebot_navigation.ros.slam.explore_node import ExploreNode

pytestmark = pytest.mark.timeout(120)


@pytest.fixture
def explore(context):
    node = ExploreNode(context=context)
    yield node
    node.destroy_node()


def set_one(node, name, value):
    return node.set_parameters([Parameter(name, value=value)])[0]


def test_a_live_change_reaches_the_frontier_search_and_keeps_the_goals_given_up(explore):
    explore.explorer.goal_failed((1.0, 2.0))
    assert set_one(explore, "clearance", 0.5).successful
    assert set_one(explore, "progress_timeout", 12.0).successful
    assert set_one(explore, "blacklist_radius", 0.8).successful
    assert explore.params.clearance == 0.5 and explore.explorer.clearance == 0.5
    assert explore.explorer.progress_timeout == 12.0 and explore.explorer.blacklist_radius == 0.8
    assert explore.explorer.blacklist == ((1.0, 2.0),)       # a goal given up stays given up


def test_a_new_planner_frequency_restarts_the_search_timer(explore):
    old = explore._timer
    assert old.timer_period_ns == round(1e9 / 0.33)
    assert set_one(explore, "planner_frequency", 2).successful          # an int for a float is fine
    assert explore._timer.timer_period_ns == 500_000_000
    timers = list(explore.timers)
    assert explore._timer in timers and old not in timers


def test_the_map_name_to_save_is_the_one_set_last(explore):
    assert set_one(explore, "save_map", "/tmp/elsewhere").successful
    assert explore.params.save_map == "/tmp/elsewhere"


@pytest.mark.parametrize("name, value, words", [
    ("clearance", -0.1, ["clearance", "-0.1"]),
    ("clearance", float("nan"), ["clearance"]),
    ("planner_frequency", 0.0, ["planner_frequency"]),
    ("progress_timeout", 1e308, ["progress_timeout"]),
    ("costmap_topic", "other_map", ["costmap_topic", "restart"]),
    ("robot_base_frame", "base_footprint", ["robot_base_frame", "restart"]),
])
def test_bad_changes_are_refused_with_the_reason_and_nothing_changes(explore, name, value, words):
    before, explorer = explore.params, explore.explorer
    result = set_one(explore, name, value)
    assert not result.successful
    assert all(word in result.reason for word in words), result.reason
    assert explore.params is before and explore.explorer is explorer


def test_a_name_the_node_does_not_have_is_refused_naming_the_closest_one(explore):
    """(Over the parameter service rclpy turns the exception into the request's failed result, with this text.)"""
    with pytest.raises(ParameterNotDeclaredException, match="'clearence' is not a parameter of /explore .*'clearance'"):
        set_one(explore, "clearence", 0.5)
