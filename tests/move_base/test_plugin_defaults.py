"""move_base without base_local_planner in its parameters starts the local planner this package has."""

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.plugins import TEB_LOCAL_PLANNER
from simplebot_navigation.ros.plugins import LOCAL_PLANNERS


def test_the_default_local_planner_is_one_move_base_can_build():
    cfg = MoveBaseConfig.from_params({})
    assert cfg.base_local_planner == TEB_LOCAL_PLANNER
    assert LOCAL_PLANNERS.resolve(cfg.base_local_planner) is not None
