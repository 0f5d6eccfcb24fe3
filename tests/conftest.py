"""Fixtures shared by the in-process ROS tests."""

import pytest
import rclpy


def fresh_context():
    """An rclpy Context of the test's own, shut down afterwards (the default context stays untouched)."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    ctx.try_shutdown()


@pytest.fixture(scope="module")
def context():
    yield from fresh_context()
