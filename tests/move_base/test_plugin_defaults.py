"""move_base without base_local_planner in its parameters starts the local planner this package has."""

from simplebot_navigation.move_base.config import MoveBaseConfig
from simplebot_navigation.move_base.plugins import LOCAL_PLANNERS, TEB_LOCAL_PLANNER


def test_the_default_local_planner_is_one_move_base_can_build():
    cfg = MoveBaseConfig.from_params({})
    assert cfg.base_local_planner == TEB_LOCAL_PLANNER
    assert callable(LOCAL_PLANNERS.spec(cfg.base_local_planner).load())
