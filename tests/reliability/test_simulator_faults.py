"""The simulator's fault injection: what it accepts, what it refuses, and when delayed transforms come out."""

import pytest
from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from rclpy.parameter import Parameter

from simplebot_navigation.ros.simulator.simulator_faults import SimulatorFaults


@pytest.fixture
def faults(context):
    node = Node("simulator", context=context)
    yield SimulatorFaults(node, ["front_laser_link", "back_laser_link"]), node
    node.destroy_node()


def set_fault(node, name, value):
    return node.set_parameters([Parameter(name, value=value)])[0]


@pytest.mark.parametrize("name, value, message", [
    ("faults.scan_dropout", "side_laser_link", "unknown laser frame(s) ['side_laser_link']"),
    ("faults.tf_delay", -0.5, "expected seconds in [0, 5]"),
    ("faults.tf_delay", float("nan"), "expected seconds in [0, 5], got nan"),
    ("faults.tf_delay", 60.0, "expected seconds in [0, 5]"),
    ("faults.odometry_dropout", "yes", "expected true or false"),
])
def test_bad_faults_are_refused_with_the_reason(faults, name, value, message):
    injected, node = faults
    result = set_fault(node, name, value)
    assert not result.successful and message in result.reason and name in result.reason
    assert injected.describe() == "none"


def test_scan_dropout_names_frames_or_all(faults):
    injected, node = faults
    assert set_fault(node, "faults.scan_dropout", "front_laser_link").successful
    assert injected.drops_scan("front_laser_link") and not injected.drops_scan("back_laser_link")
    assert set_fault(node, "faults.scan_dropout", "all").successful
    assert injected.drops_scan("back_laser_link")
    assert set_fault(node, "faults.scan_dropout", "").successful
    assert not injected.drops_scan("front_laser_link")


def stamped(t):
    tf = TransformStamped()
    tf.header.stamp.sec = t
    return [tf]


def test_delayed_transforms_come_out_after_the_delay_and_all_at_once_when_it_ends(faults):
    injected, node = faults
    assert injected.transforms_due(1.0, stamped(1)) == stamped(1)
    assert set_fault(node, "faults.tf_delay", 2).successful        # an integer is seconds too
    assert injected.transforms_due(2.0, stamped(2)) == []
    assert injected.transforms_due(3.0, stamped(3)) == []
    assert [tf.header.stamp.sec for tf in injected.transforms_due(4.0, stamped(4))] == [2]
    assert set_fault(node, "faults.tf_delay", 0.0).successful
    assert [tf.header.stamp.sec for tf in injected.transforms_due(5.0, stamped(5))] == [3, 4, 5]
