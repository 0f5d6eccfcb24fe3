"""A plugin of each kind, registered from this test only, loaded by move_base by its type name: the examples of
docs/plugins.md. Each is one module under tests/plugins/ plus the registration below."""

import contextlib

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import LETHAL_OBSTACLE
from simplebot_navigation.costmap.costmap_core import CostmapCore
from simplebot_navigation.costmap.plugins import LAYERS, LayerSpec
from simplebot_navigation.launch.loader import LaunchError
from simplebot_navigation.move_base.parameter_tree import parameter_table
from simplebot_navigation.move_base.plugins import GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS, PluginSpec
from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D
from tests.plugins.keep_out_layer import KeepOutLayer, KeepOutParams
from tests.plugins.pure_pursuit import PurePursuit, PurePursuitParams, pure_pursuit_config
from tests.plugins.straight_line_planner import StraightLineParams, StraightLinePlanner, straight_line_config
from tests.plugins.wait_recovery import WaitParams, WaitRecovery

KEEP_OUT = LayerSpec("KeepOutLayer", ("example::KeepOutLayer",), KeepOutLayer, KeepOutParams)
STRAIGHT = PluginSpec("example/StraightLinePlanner", "tests.plugins.straight_line_planner:StraightLinePlanner",
                      StraightLineParams, straight_line_config)
PURSUIT = PluginSpec("example/PurePursuit", "tests.plugins.pure_pursuit:PurePursuit", PurePursuitParams,
                     pure_pursuit_config)
WAIT = PluginSpec("example/WaitRecovery", "tests.plugins.wait_recovery:create", WaitParams)
ZONE = [1.0, -2.0, 1.6, -1.0]
OVERRIDES = (
    "base_global_planner=example/StraightLinePlanner", "base_local_planner=example/PurePursuit",
    "PurePursuit.speed=0.4", "recovery_behaviors=[{name: wait, type: example/WaitRecovery}]",
    "wait.wait_duration=2.0",
    "global_costmap.plugins=[{name: keep_out, type: 'example::KeepOutLayer'}, "
    "{name: obstacles, type: 'costmap_2d::ObstacleLayer'}, {name: inflation_layer, type: 'costmap_2d::InflationLayer'}]",
    f"global_costmap.keep_out.zone={ZONE}",
)


@pytest.fixture
def examples():
    with contextlib.ExitStack() as stack:
        stack.enter_context(LAYERS.registered(KEEP_OUT))
        for registry, spec in ((GLOBAL_PLANNERS, STRAIGHT), (LOCAL_PLANNERS, PURSUIT), (RECOVERY_BEHAVIORS, WAIT)):
            stack.enter_context(registry.registered(spec))
        yield


def test_a_registered_layer_marks_the_costmap(examples):
    costmap = CostmapCore("c", {"plugins": [{"name": "keep_out", "type": "example::KeepOutLayer"}],
                            "keep_out": {"zone": ZONE}, "width": 4, "height": 4, "origin_x": -2.0, "origin_y": -2.0,
                            "resolution": 0.1, "robot_radius": 0.3})
    costmap.update_map(0.0, 0.0, 0.0)
    inside, outside = costmap.costmap.world_to_map(1.3, -1.5), costmap.costmap.world_to_map(0.5, 0.5)
    assert costmap.costmap.get_cost(*inside) == LETHAL_OBSTACLE
    assert costmap.costmap.get_cost(*outside) == 0


def test_their_parameters_are_in_the_parameter_tree(examples):
    table = parameter_table({"base_local_planner": "example/PurePursuit", "recovery_behaviors": [
        {"name": "wait", "type": "example/WaitRecovery"}]})
    assert {"PurePursuit.lookahead", "wait.wait_duration", "NavfnROS.allow_unknown"} <= set(table)
    assert table["PurePursuit.speed"].high == 1.0


def test_move_base_loads_each_by_type_name_and_drives_with_them(examples):
    with NavigationSession("empty", robot="round", overrides=OVERRIDES) as session:
        session.wait_ready(wall_timeout_s=120.0)
        move_base = session.move_base
        assert isinstance(move_base.planner, StraightLinePlanner) and isinstance(move_base.controller, PurePursuit)
        assert isinstance(move_base.recovery_instances["wait"], WaitRecovery)
        assert move_base.get_parameter("wait.wait_duration").value == 2.0
        assert move_base.get_parameter("PurePursuit.speed").value == 0.4
        assert list(move_base.get_parameter("global_costmap.keep_out.zone").value) == ZONE
        costmap = move_base.global_costmap.costmap
        assert costmap.get_cost(*costmap.world_to_map(1.3, -1.5)) == LETHAL_OBSTACLE
        run = session.send_goal(Pose2D(2.0, 0.5, 0.0, "ahead"))
        session.run_until(stop=lambda: run.done, wall_timeout_s=300.0)
        assert run.status == "SUCCEEDED", run.reason
        pose = session.pose()
        assert np.hypot(pose.x - 2.0, pose.y - 0.5) <= 0.2


def test_an_unregistered_type_is_refused_naming_the_known_ones():
    with pytest.raises(LaunchError, match="unknown type 'example/PurePursuit'; known types: "
                                          "teb_local_planner/TebLocalPlannerROS"):
        NavigationSession("empty", overrides=("base_local_planner=example/PurePursuit",))
