"""A plugin of each kind, registered from this test only, loaded by move_base by its type name: the examples of
docs/plugins.md. Each is one module under tests/plugins/ that holds its registration (``SPEC``), registered
below as an application would register its own."""

import contextlib
import math

import numpy as np
import pytest

from simplebot_navigation.costmap.cost_values import FREE_SPACE, LETHAL_OBSTACLE
from simplebot_navigation.costmap.costmap_core import CostmapCore
from simplebot_navigation.costmap.params import resolve_costmap_params
from simplebot_navigation.costmap.plugins import LAYERS
from simplebot_navigation.launch.loader import LaunchError
from simplebot_navigation.move_base.parameter_tree import parameter_table
from simplebot_navigation.move_base.plugins import GLOBAL_PLANNERS, LOCAL_PLANNERS, RECOVERY_BEHAVIORS
from simplebot_navigation.scenarios.session import NavigationSession
from simplebot_navigation.sim.world import Pose2D
from tests.plugins import keep_out_layer, latest_hits_layer, pure_pursuit, straight_line_planner, wait_recovery
from tests.plugins.latest_hits_layer import LatestHitsLayer
from tests.plugins.pure_pursuit import PurePursuit
from tests.plugins.straight_line_planner import StraightLinePlanner
from tests.plugins.wait_recovery import WaitRecovery

ZONE = [1.0, -2.0, 1.6, -1.0]
#: a box beside the way to the goal, where only the sensor layer marks the local costmap
BOX_CENTER, BOX_HALF = (1.0, 1.5), 0.2
WORLD = f"""name: box_beside
walls: []
boxes:
  - {{center: [{BOX_CENTER[0]}, {BOX_CENTER[1]}], size: [{2 * BOX_HALF}, {2 * BOX_HALF}], yaw: 0.0, height: 1.0}}
cylinders: []
start: {{x: 0.0, y: 0.0, yaw: 0.0}}
goals: []
"""
OVERRIDES = (
    "base_global_planner=example/StraightLinePlanner", "base_local_planner=example/PurePursuit",
    "PurePursuit.speed=0.4", "recovery_behaviors=[{name: wait, type: example/WaitRecovery}]",
    "wait.wait_duration=2.0",
    "global_costmap.plugins=[{name: keep_out, type: 'example::KeepOutLayer'}, "
    "{name: obstacles, type: 'costmap_2d::ObstacleLayer'}, {name: inflation_layer, type: 'costmap_2d::InflationLayer'}]",
    f"global_costmap.keep_out.zone={ZONE}",
    # the sensor layer takes the obstacle layer's place and its namespace (front_laser, back_laser)
    "local_costmap.plugins=[{name: obstacles, type: 'example::LatestHitsLayer'}, "
    "{name: inflation_layer, type: 'costmap_2d::InflationLayer'}]",
)
HITS = {"plugins": [{"name": "hits", "type": "example::LatestHitsLayer"}], "width": 4, "height": 4,
        "origin_x": -2.0, "origin_y": -2.0, "resolution": 0.1, "robot_radius": 0.3}


@pytest.fixture
def examples():
    registrations = ((LAYERS, keep_out_layer.SPEC), (LAYERS, latest_hits_layer.SPEC),
                     (GLOBAL_PLANNERS, straight_line_planner.SPEC), (LOCAL_PLANNERS, pure_pursuit.SPEC),
                     (RECOVERY_BEHAVIORS, wait_recovery.SPEC))
    with contextlib.ExitStack() as stack:
        for registry, spec in registrations:
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


def _hits_costmap(obstacle_range: float) -> dict:
    return {**HITS, "hits": {"observation_sources": "scan", "scan": {
        "data_type": "LaserScan", "expected_update_rate": 0.5, "obstacle_range": obstacle_range}}}


def test_a_registered_sensor_layer_takes_its_sources_messages_live_changes_and_staleness(examples):
    now = [0.0]
    costmap = CostmapCore("c", _hits_costmap(1.0), clock=lambda: now[0])
    assert costmap.config.warnings == []
    assert [(layer, source.topic) for layer, source in costmap.observation_sources()] == [("hits", "scan")]

    def scan_and_update(t: float) -> tuple[int, ...]:
        """Two beams, 0.53 m along +x and 1.53 m along +y; the costs where they end."""
        now[0] = t
        ranges, angles = [0.53, 1.53], [0.0, math.pi / 2]
        costmap.add_laser_scan("scan", ranges, 0.0, math.pi / 2, 0.1, 5.0, (0.0, 0.0, 0.0, 0.0), t)
        costmap.update_map(0.0, 0.0, 0.0)
        grid = costmap.costmap
        return tuple(grid.get_cost(*grid.world_to_map(r * math.cos(a), r * math.sin(a)))
                     for r, a in zip(ranges, angles))

    assert scan_and_update(0.1) == (LETHAL_OBSTACLE, FREE_SPACE)       # 1.5 m is beyond obstacle_range
    costmap.reconfigure(resolve_costmap_params(_hits_costmap(2.0), "c"))
    assert scan_and_update(0.2) == (LETHAL_OBSTACLE, LETHAL_OBSTACLE)
    assert costmap.is_current()
    now[0] = 1.0                                                       # silent for longer than 0.5 s + a period
    costmap.update_map(0.0, 0.0, 0.0)
    assert not costmap.is_current() and costmap.stale_sources() == ["hits/scan"]


def test_their_parameters_are_in_the_parameter_tree(examples):
    table = parameter_table({"base_local_planner": "example/PurePursuit", "recovery_behaviors": [
        {"name": "wait", "type": "example/WaitRecovery"}], "local_costmap": _hits_costmap(1.0)})
    assert {"PurePursuit.lookahead", "wait.wait_duration", "NavfnROS.allow_unknown", "local_costmap.hits.enabled",
            "local_costmap.hits.scan.obstacle_range", "local_costmap.hits.scan.topic"} <= set(table)
    assert table["PurePursuit.speed"].high == 1.0
    assert not table["local_costmap.hits.scan.topic"].dynamic


def _lethal_points(costmap_ros) -> np.ndarray:
    """World (x, y) of every lethal cell of a costmap."""
    with costmap_ros.lock:
        grid = costmap_ros.costmap
        rows, cols = np.nonzero(grid.costmap == LETHAL_OBSTACLE)
        return np.array([grid.map_to_world(mx, my) for mx, my in zip(cols, rows)]).reshape(-1, 2)


def _at_the_box(points: np.ndarray) -> np.ndarray:
    margin = BOX_HALF + 0.15
    return (np.abs(points[:, 0] - BOX_CENTER[0]) <= margin) & (np.abs(points[:, 1] - BOX_CENTER[1]) <= margin)


def test_move_base_loads_each_by_type_name_and_drives_with_them(examples, tmp_path):
    world = tmp_path / "box_beside.yaml"
    world.write_text(WORLD)
    with NavigationSession(str(world), robot="round", overrides=OVERRIDES) as session:
        session.wait_ready(wall_timeout_s=120.0)
        move_base = session.move_base
        assert isinstance(move_base.planner, StraightLinePlanner) and isinstance(move_base.controller, PurePursuit)
        assert isinstance(move_base.recovery_instances["wait"], WaitRecovery)
        assert isinstance(move_base.local_costmap.cm.layer("obstacles"), LatestHitsLayer)
        assert move_base.get_parameter("wait.wait_duration").value == 2.0
        assert move_base.get_parameter("PurePursuit.speed").value == 0.4
        assert list(move_base.get_parameter("global_costmap.keep_out.zone").value) == ZONE
        assert move_base.get_parameter("local_costmap.obstacles.front_laser.topic").value == "/front_laser/front_scan"
        costmap = move_base.global_costmap.costmap
        assert costmap.get_cost(*costmap.world_to_map(1.3, -1.5)) == LETHAL_OBSTACLE
        # the sensor layer, fed by the lasers, is all that marks the local costmap: at the box, nowhere else
        assert session.run_until(stop=lambda: _at_the_box(_lethal_points(move_base.local_costmap)).any(),
                                 wall_timeout_s=60.0)
        assert _at_the_box(_lethal_points(move_base.local_costmap)).all()
        run = session.send_goal(Pose2D(2.0, 0.5, 0.0, "ahead"))
        session.run_until(stop=lambda: run.done, wall_timeout_s=300.0)
        assert run.status == "SUCCEEDED", run.reason
        pose = session.pose()
        assert np.hypot(pose.x - 2.0, pose.y - 0.5) <= 0.2


def test_an_unregistered_type_is_refused_naming_the_known_ones():
    with pytest.raises(LaunchError, match="unknown type 'example/PurePursuit'; known types: "
                                          "mppi_local_planner/MPPILocalPlannerROS, teb_local_planner/TebLocalPlannerROS"):
        NavigationSession("empty", overrides=("base_local_planner=example/PurePursuit",))
