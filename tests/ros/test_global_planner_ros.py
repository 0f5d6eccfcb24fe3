"""GlobalPlannerROS in-process: a move_base node, a stand-in global costmap, real topics and the GetPlan service.

The map is the lab's global costmap size (150 x 150 cells of 0.2 m, origin (-15, -15)) with a wall along
x in [0, 0.2) that has one gap for y in [4, 6), and a hand-made inflation on both sides of it:
253 (blocked for the planner) in the next cell, then 100, then 30. Start and goal sit on cell centres.
"""

import math
import threading
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, TransformStamped
from nav_msgs.msg import OccupancyGrid, Path
from nav_msgs.srv import GetPlan
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.planning import GLOBAL_PLANNER, NAVFN, GlobalPlannerConfig, PlanFailure
from simplebot_navigation.ros.conversions import path_to_array, xyyaw_to_pose
from simplebot_navigation.ros.move_base.global_planner_ros import GlobalPlannerROS, resolved_parameters
from simplebot_navigation.ros.tf import Buffer

RES, ORIGIN, CELLS = 0.2, -15.0, 150
WALL_COL = 75                       # x in [0, 0.2)
GAP_ROWS = range(95, 105)           # y in [4, 6)
START = (-4.9, 0.1, 0.0)            # cell (50, 75) centre
GOAL = (5.1, 0.1, math.pi / 2)      # cell (100, 75) centre
FRAME = "map"


def plan_request(goal, start, tolerance: float, goal_frame: str, start_frame: str) -> GetPlan.Request:
    """A nav_msgs/GetPlan request for (x, y, yaw) poses; no start: the robot's pose."""
    request = GetPlan.Request(tolerance=float(tolerance))
    request.goal = PoseStamped(pose=xyyaw_to_pose(*goal))
    request.goal.header.frame_id = goal_frame
    if start is not None:
        request.start = PoseStamped(pose=xyyaw_to_pose(*start))
        request.start.header.frame_id = start_frame
    return request


def wall_map() -> Costmap2D:
    cm = Costmap2D(CELLS, CELLS, RES, ORIGIN, ORIGIN)
    for offset, cost in ((0, LETHAL_OBSTACLE), (1, INSCRIBED_INFLATED_OBSTACLE), (2, 100), (3, 30)):
        cm.costmap[:, WALL_COL - offset] = cost
        cm.costmap[:, WALL_COL + offset] = cost
    cm.costmap[GAP_ROWS.start:GAP_ROWS.stop, WALL_COL - 3:WALL_COL + 4] = 0
    return cm


class CountingLock:
    """An RLock that knows whether it is held, to check what the planner reads under it."""

    def __init__(self):
        self._lock = threading.RLock()
        self.depth = 0

    def __enter__(self):
        self._lock.acquire()
        self.depth += 1
        return self

    def __exit__(self, *exc):
        self.depth -= 1
        self._lock.release()


class StandInCostmapROS:
    """The part of Costmap2DROS the planner uses."""

    def __init__(self):
        self.lock = CountingLock()
        self.global_frame = "/" + FRAME       # a leading slash, as ROS 1 configs write it
        self.tf = Buffer()                     # no transforms: a pose in another frame cannot be planned
        self.robot_pose = (*START, None)
        self.grid = wall_map()
        self.reads_outside_lock = 0

    @property
    def costmap(self) -> Costmap2D:
        if self.lock.depth == 0:
            self.reads_outside_lock += 1
        return self.grid

    def get_robot_pose(self):
        return self.robot_pose


class RecordingLogger:
    def __init__(self):
        self.records = []

    def warning(self, msg, **_throttle):
        self.records.append(("warning", msg))

    def error(self, msg, **_throttle):
        self.records.append(("error", msg))


class Harness:
    def __init__(self, context: Context):
        self.node = Node("move_base", context=context, automatically_declare_parameters_from_overrides=True,
                         parameter_overrides=[Parameter("GlobalPlanner.publish_potential", value=True)])
        self.costmap_ros = StandInCostmapROS()
        self.planner = GlobalPlannerROS(self.node, GLOBAL_PLANNER, self.costmap_ros)
        self.planner.logger = self.log = RecordingLogger()
        self.probe = Node("probe", context=context)
        self.plans: list[Path] = []
        self.potentials: list[OccupancyGrid] = []
        self.probe.create_subscription(Path, "/move_base/GlobalPlanner/plan", self.plans.append, 10)
        self.probe.create_subscription(OccupancyGrid, "/move_base/GlobalPlanner/potential",
                                       self.potentials.append, 10)
        self.client = self.probe.create_client(GetPlan, "/move_base/GlobalPlanner/make_plan")
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.probe)
        self.spin_until(lambda: (self.planner.plan_pub.get_subscription_count() > 0
                                 and self.planner.potential_pub.get_subscription_count() > 0
                                 and self.client.service_is_ready()))

    def spin_until(self, condition, timeout=5.0):
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, "timed out"
            self.executor.spin_once(timeout_sec=0.02)

    def make_plan(self, *args, **kwargs):
        before = len(self.plans)
        result = self.planner.make_plan(*args, **kwargs)
        self.spin_until(lambda: len(self.plans) > before)
        return result, self.plans[-1]

    def call(self, goal, start=None, tolerance=0.0, goal_frame=FRAME, start_frame=FRAME) -> Path:
        future = self.client.call_async(plan_request(goal, start, tolerance, goal_frame, start_frame))
        self.spin_until(future.done)
        return future.result().plan

    def close(self):
        self.planner.destroy()
        self.executor.shutdown()
        self.probe.destroy_node()
        self.node.destroy_node()


@pytest.fixture(scope="module")
def ros(context):
    harness = Harness(context)
    yield harness
    harness.close()


@pytest.fixture(autouse=True)
def fresh_log(request):
    if "ros" in request.fixturenames:
        request.getfixturevalue("ros").log.records.clear()


def cell_costs(costmap: Costmap2D, poses: np.ndarray) -> np.ndarray:
    mx = ((poses[:, 0] - ORIGIN) / RES).astype(int)
    my = ((poses[:, 1] - ORIGIN) / RES).astype(int)
    return costmap.costmap[my, mx]


def test_plan_is_published_in_the_global_frame_from_start_to_goal_through_the_gap(ros):
    result, msg = ros.make_plan(START, GOAL)
    assert result.ok and result.failure is None
    assert msg.header.frame_id == FRAME and all(p.header.frame_id == FRAME for p in msg.poses)
    poses = path_to_array(msg)
    np.testing.assert_allclose(poses, result.poses, atol=1e-9)
    assert math.dist(poses[0, :2], START[:2]) <= RES
    np.testing.assert_allclose(poses[-1], GOAL, atol=1e-9)          # the goal pose, with its yaw
    assert cell_costs(ros.costmap_ros.grid, poses).max() < INSCRIBED_INFLATED_OBSTACLE
    crossing = poses[np.abs(poses[:, 0] - 0.1) < 0.1]
    assert len(crossing) and np.all((crossing[:, 1] >= 4.0) & (crossing[:, 1] < 6.0))
    assert ros.costmap_ros.reads_outside_lock == 0
    assert ros.log.records == []


def test_potential_is_published_with_the_costmap_geometry(ros):
    before = len(ros.potentials)
    result, _ = ros.make_plan(START, GOAL)
    ros.spin_until(lambda: len(ros.potentials) > before)
    grid = ros.potentials[-1]
    assert grid.header.frame_id == FRAME
    assert (grid.info.width, grid.info.height, grid.info.resolution) == (CELLS, CELLS, pytest.approx(RES))
    assert (grid.info.origin.position.x, grid.info.origin.position.y) == (ORIGIN, ORIGIN)
    data = np.array(grid.data, dtype=np.int8).reshape(CELLS, CELLS)
    assert data[75, 50] == 0                                         # the start cell
    assert data.max() == 100                                         # publish_scale
    assert data[75, 100] >= 0                                        # the goal was reached
    wall = np.ones(CELLS, bool)
    wall[GAP_ROWS.start:GAP_ROWS.stop] = False
    assert np.all(data[wall, WALL_COL] == -1)                        # lethal cells never get a potential
    peak = result.potential[result.potential < 1e9].max()
    assert data[75, 100] == int(result.potential[75, 100] * 100 / peak)


def test_parameters_are_declared_with_ros1_defaults_and_the_override(ros):
    node = ros.node
    assert node.get_parameter("GlobalPlanner.publish_potential").value is True
    assert node.get_parameter("GlobalPlanner.use_dijkstra").value is True
    assert node.get_parameter("GlobalPlanner.orientation_mode").value == 1
    assert node.get_parameter("GlobalPlanner.cost_factor").value == 3.0
    assert node.get_parameter("GlobalPlanner.default_tolerance").value == 0.0
    declared = {name: p.value for name, p in node.get_parameters_by_prefix("GlobalPlanner").items()}
    assert GlobalPlannerConfig.from_params(declared) == ros.planner.config


def test_declared_defaults_carry_the_description_and_range_of_their_spec(ros):
    cost_factor = ros.node.describe_parameter("GlobalPlanner.cost_factor")
    assert cost_factor.description.startswith("factor applied to each costmap cost")
    assert [(r.from_value, r.to_value) for r in cost_factor.floating_point_range] == [(0.01, 5.0)]
    lethal = ros.node.describe_parameter("GlobalPlanner.lethal_cost")
    assert [(r.from_value, r.to_value) for r in lethal.integer_range] == [(1, 255)]
    window = ros.node.describe_parameter("GlobalPlanner.planner_window_x").description
    assert "accepted, not implemented" in window


def test_get_plan_honours_the_tolerance_for_a_goal_inside_the_wall(ros):
    goal = (0.05, -4.9, 0.0)                 # wall cell (75, 50)
    assert len(ros.call(goal, START, tolerance=0.0).poses) == 0
    assert any("cannot enter" in msg for level, msg in ros.log.records if level == "error")
    plan = ros.call(goal, START, tolerance=0.5)
    assert plan.header.frame_id == FRAME
    poses = path_to_array(plan)
    # The nearest reachable cell centre: (-0.3, -4.9), 0.35 m away (the 253 cells next to the wall are
    # blocked; (0.5, -4.9) on the far side is 0.45 m away).
    np.testing.assert_allclose(poses[-1, :2], (-0.3, -4.9), atol=1e-9)
    assert math.dist(poses[0, :2], START[:2]) <= RES


def test_get_plan_without_a_start_frame_starts_at_the_robot(ros):
    ros.costmap_ros.robot_pose = (-4.9, -2.9, 0.0, None)
    try:
        poses = path_to_array(ros.call(GOAL, start=None))
    finally:
        ros.costmap_ros.robot_pose = (*START, None)
    assert math.dist(poses[0, :2], (-4.9, -2.9)) <= RES
    np.testing.assert_allclose(poses[-1], GOAL, atol=1e-9)


def test_get_plan_rejects_untransformable_frames_and_nan_with_a_reason(ros):
    before = len(ros.plans)
    plan = ros.call(GOAL, START, goal_frame="odom")
    assert len(plan.poses) == 0 and plan.header.frame_id == FRAME
    assert any("cannot transform the goal from odom to map" in msg for _, msg in ros.log.records)
    plan = ros.call(GOAL, (-4.9, 0.1, 0.0), start_frame="base_link")
    assert len(plan.poses) == 0
    assert any("cannot transform the start from base_link to map" in msg for _, msg in ros.log.records)
    plan = ros.call((float("nan"), 0.1, 0.0), START)
    assert len(plan.poses) == 0
    assert any("goal has a NaN or inf" in msg for _, msg in ros.log.records)
    plan = ros.call(GOAL, START, tolerance=float("nan"))
    assert len(plan.poses) == 0
    assert any("tolerance" in msg for _, msg in ros.log.records)
    ros.spin_until(lambda: len(ros.plans) >= before + 4)
    assert all(len(p.poses) == 0 for p in ros.plans[before:before + 4])   # every request shows on ~plan


def test_get_plan_moves_poses_from_other_frames_into_the_global_frame(ros):
    shifted = TransformStamped(child_frame_id="shifted")
    shifted.header.frame_id = FRAME
    shifted.transform.translation.x = 1.0
    shifted.transform.rotation.w = 1.0
    ros.costmap_ros.tf.set_transform_static(shifted, "test")
    try:
        poses = path_to_array(ros.call((GOAL[0] - 1.0, GOAL[1], GOAL[2]), START, goal_frame="shifted"))
    finally:
        ros.costmap_ros.tf = Buffer()
    np.testing.assert_allclose(poses[-1], GOAL, atol=1e-9)


def test_goal_off_the_map_gives_an_empty_plan_a_throttled_warning_and_planning_goes_on(ros):
    for _ in range(3):
        result, msg = ros.make_plan(START, (40.0, 0.0, 0.0))
        assert not result.ok and result.failure is PlanFailure.GOAL_OFF_MAP
        assert len(msg.poses) == 0 and msg.header.frame_id == FRAME
    warnings = [msg for level, msg in ros.log.records if level == "warning"]
    assert len(warnings) == 1 and "off the global costmap" in warnings[0]
    result, msg = ros.make_plan(START, GOAL)
    assert result.ok and len(msg.poses) > 0


def test_navfn_publishes_under_its_own_name(ros, context):
    received: list[Path] = []
    sub = ros.probe.create_subscription(Path, "/move_base/NavfnROS/plan", received.append, 10)
    navfn = GlobalPlannerROS(ros.node, NAVFN, ros.costmap_ros)
    try:
        assert ros.node.get_parameter("NavfnROS.visualize_potential").value is False
        assert ros.node.get_parameter("NavfnROS.allow_unknown").value is True
        ros.spin_until(lambda: navfn.plan_pub.get_subscription_count() > 0)
        result = navfn.make_plan(START, GOAL)
        ros.spin_until(lambda: len(received) > 0)
        assert result.ok
        assert received[-1].header.frame_id == FRAME
        np.testing.assert_allclose(path_to_array(received[-1])[-1, :2], GOAL[:2], atol=1e-9)
    finally:
        navfn.destroy()
        ros.probe.destroy_subscription(sub)


def test_unknown_planner_type_is_named(ros):
    with pytest.raises(ValueError, match="carrot_planner/CarrotPlanner"):
        GlobalPlannerROS(ros.node, "carrot_planner/CarrotPlanner", ros.costmap_ros)


def test_resolved_parameters_load_back_for_both_types():
    for config in (GlobalPlannerConfig.from_params({"use_dijkstra": False, "orientation_mode": 3}),
                   GlobalPlannerConfig.from_navfn_params({"default_tolerance": 0.5})):
        load = GlobalPlannerConfig.from_navfn_params if config.navfn else GlobalPlannerConfig.from_params
        assert load(resolved_parameters(config)) == config
