"""The suite's isolation (tests/conftest.py): a ROS domain per test, and leftovers fail the test that left them."""

from pathlib import Path

pytest_plugins = ["pytester"]

CONFTEST = Path(__file__).with_name("conftest.py").read_text()

LEAKY = '''
import subprocess, sys, os
import pytest
import rclpy

kept = []  # what a test forgets to stop is usually still referenced somewhere (an executor, a global)

def test_leaves_a_node(context):
    kept.append(rclpy.create_node("forgotten", context=context))

def test_leaves_a_process():
    kept.append(subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"]))

def test_leaves_a_context():
    kept.append(rclpy.Context())
    rclpy.init(context=kept[-1])

def test_tidy():
    pass
'''

DOMAINS = '''
import os
import pytest
import rclpy

seen = {}

def test_first():
    seen["first"] = os.environ["ROS_DOMAIN_ID"]

def test_second():
    seen["second"] = os.environ["ROS_DOMAIN_ID"]
    assert seen["second"] != seen["first"]

def test_a_module_context_keeps_the_module_domain(context):
    node = rclpy.create_node("probe", context=context)
    try:
        assert str(context.get_domain_id()) == os.environ["ROS_DOMAIN_ID"]
    finally:
        node.destroy_node()
'''


def test_whatever_a_test_leaves_running_fails_it(pytester):
    pytester.makeconftest(CONFTEST)
    pytester.makepyfile(test_leaky=LEAKY)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-p", "no:xdist")
    result.assert_outcomes(passed=4, errors=3)
    result.stdout.fnmatch_lines([
        "*ERROR at teardown of test_leaves_a_node*", "*the test left running: node /forgotten",
        "*ERROR at teardown of test_leaves_a_process*", "*the test left running: process * time.sleep(60)",
        "*ERROR at teardown of test_leaves_a_context*", "*the test left running: rclpy context in ROS domain *",
    ])


def test_each_test_gets_a_domain_of_its_own_unless_the_module_runs_ros(pytester):
    pytester.makeconftest(CONFTEST)
    pytester.makepyfile(test_domains=DOMAINS)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-p", "no:xdist")
    result.assert_outcomes(passed=3)
