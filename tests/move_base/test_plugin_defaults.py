"""move_base without base_local_planner in its parameters starts the local planner this package has, and a type
is registered once (tests/plugins/test_entry_points.py checks that every registered implementation exists)."""

import dataclasses

import pytest

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.plugins import LOCAL_PLANNERS
from simplebot_navigation.teb.plugin import TEB_LOCAL_PLANNER


def test_the_default_local_planner_is_one_move_base_can_build():
    cfg = MoveBaseConfig.from_params({})
    assert cfg.base_local_planner == TEB_LOCAL_PLANNER
    assert callable(LOCAL_PLANNERS.spec(cfg.base_local_planner).load())


def test_a_type_is_registered_once_and_a_test_registration_ends_with_its_block():
    spec = LOCAL_PLANNERS.spec(TEB_LOCAL_PLANNER)
    with pytest.raises(ValueError, match="registered already"):
        LOCAL_PLANNERS.register(spec)
    twin = dataclasses.replace(spec, type="example/Twin")
    with LOCAL_PLANNERS.registered(twin):
        assert LOCAL_PLANNERS.spec("example/Twin") is twin
    assert "example/Twin" not in LOCAL_PLANNERS.types
