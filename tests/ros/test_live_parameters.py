"""Live parameter changes of move_base (ROS 1 dynamic_reconfigure semantics): what the parameter services
accept takes effect at the next control cycle, what they refuse they refuse with the reason and the old value
stays, and every parameter is described. The requests go to /move_base's SetParameters, GetParameters and
DescribeParameters services from a node of its own, as ``ros2 param set/get/describe`` send them, with the
simulator and move_base in lockstep in the empty world (same run every time, budgets in simulated time)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Twist
from nav2_msgs.action import Spin
from rcl_interfaces.srv import DescribeParameters, GetParameters, SetParameters
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python

from simplebot_navigation.costmap.costmap_core import CostmapCore
from simplebot_navigation.costmap.footprint import parse_footprint
from simplebot_navigation.move_base.live_parameters import LiveParameters
from simplebot_navigation.parameters import value_of
from simplebot_navigation.parameters.overrides import lookup
from simplebot_navigation.ros.params import NODE_LEVEL
from simplebot_navigation.scenarios import NavigationSession
from simplebot_navigation.sim.world import Pose2D
from simplebot_navigation.testing.lab_params import move_base_tree

pytestmark = pytest.mark.timeout(180)
WALL_GUARD_S = 60.0
MAX_VEL_X = "TebLocalPlannerROS.max_vel_x"
SPEED_TOLERANCE = 0.005
FAR_AHEAD = Pose2D(12.0, 0.0, 0.0, "12 m ahead")   # the global costmap ends at 15 m


class ParameterClient(Node):
    """The user's side: requests to /move_base's parameter services, and every cmd_vel with its sim time."""

    def __init__(self, session: NavigationSession):
        super().__init__("live_parameter_client", context=session.context)
        self.session = session
        self.set_service = self.create_client(SetParameters, "/move_base/set_parameters")
        self.get_service = self.create_client(GetParameters, "/move_base/get_parameters")
        self.describe_service = self.create_client(DescribeParameters, "/move_base/describe_parameters")
        self.spin_action = ActionClient(self, Spin, "/spin")
        self.commands: list[tuple[float, float]] = []          # (sim time, linear.x)
        self.turns: list[tuple[float, float]] = []             # (sim time, angular.z)
        self.create_subscription(Twist, "/simplebot_controller/cmd_vel", self._on_cmd_vel, 50)

    def _on_cmd_vel(self, msg: Twist) -> None:
        self.commands.append((self.session.time, msg.linear.x))
        self.turns.append((self.session.time, msg.angular.z))

    def ready(self) -> bool:
        return all(c.service_is_ready() for c in (self.set_service, self.get_service, self.describe_service)) \
            and self.spin_action.server_is_ready()

    def spin(self, target_yaw: float) -> int:
        """A Spin goal, as Nav2's BasicNavigator.spin sends it, run to its end: its status."""
        goal = Spin.Goal(target_yaw=target_yaw)
        goal.time_allowance.sec = 20
        handle = self._wait(self.spin_action.send_goal_async(goal))
        return self._wait(handle.get_result_async(), 30.0).status

    def _wait(self, future, sim_s: float = 5.0):
        self.session.run_until(self.session.time + sim_s, future.done, wall_timeout_s=WALL_GUARD_S)
        assert future.done(), f"no answer within {sim_s} s of simulated time"
        return future.result()

    def _call(self, service, request):
        future = service.call_async(request)
        self.session.run_until(stop=future.done, wall_timeout_s=WALL_GUARD_S)
        return future.result()

    def set(self, name: str, value):
        """One SetParameters request, as `ros2 param set /move_base NAME VALUE` sends it: its result."""
        request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        return self._call(self.set_service, request).results[0]

    def get(self, name: str):
        values = self._call(self.get_service, GetParameters.Request(names=[name])).values
        return parameter_value_to_python(values[0])

    def describe(self, names: list[str]):
        return self._call(self.describe_service, DescribeParameters.Request(names=names)).descriptors

    def commands_since(self, t0: float) -> list[tuple[float, float]]:
        return [(t, v) for t, v in self.commands if t >= t0 - 1e-9]


@pytest.fixture(scope="module")
def session():
    with NavigationSession("empty") as session:
        session.wait_ready(wall_timeout_s=WALL_GUARD_S)
        session.params = ParameterClient(session)
        session.driver.add_node(session.params)
        session.run_until(stop=session.params.ready, wall_timeout_s=WALL_GUARD_S)
        yield session


@pytest.fixture
def driving(session):
    """The robot driving towards a goal far ahead; afterwards the goal is cancelled and the robot stopped."""
    run = session.send_goal(FAR_AHEAD)
    session.run_for(3.0, wall_timeout_s=WALL_GUARD_S)          # up to speed after about a second
    yield run
    session.cancel(run)
    session.run_for(2.0, lambda: run.done, wall_timeout_s=WALL_GUARD_S)


def test_max_vel_x_set_while_driving_limits_cmd_vel_within_half_a_second(session, driving):
    params = session.params
    cruising = [v for _, v in params.commands_since(session.time - 1.0)]
    assert cruising and min(cruising) > 0.38, cruising
    t0 = session.time
    try:
        result = params.set(MAX_VEL_X, 0.2)
        assert result.successful, result.reason
        assert params.get(MAX_VEL_X) == 0.2
        session.run_for(1.5, wall_timeout_s=WALL_GUARD_S)
        after = params.commands_since(t0)
        first_slow = next(t for t, v in after if v <= 0.2 + SPEED_TOLERANCE)
        assert first_slow - t0 <= 0.5, after[:12]
        assert max(v for t, v in after if t >= first_slow) <= 0.2 + SPEED_TOLERANCE
        assert max(v for t, v in after if t >= t0 + 0.5) <= 0.2 + SPEED_TOLERANCE
        assert min(v for t, v in after if t >= t0 + 1.0) > 0.15        # still driving, at the new limit
    finally:
        assert params.set(MAX_VEL_X, 0.4).successful


def test_a_spin_requested_after_max_rotational_vel_is_lowered_turns_no_faster(session):
    params = session.params
    try:
        result = params.set("behavior_server.max_rotational_vel", 0.5)
        assert result.successful, result.reason
        session.run_for(0.1, wall_timeout_s=WALL_GUARD_S)                  # the next control cycle takes it
        t0, yaw = session.time, session.pose().yaw
        assert params.spin(math.pi / 2) == GoalStatus.STATUS_SUCCEEDED
        turns = [abs(w) for t, w in params.turns if t >= t0]
        assert 0.45 < max(turns) <= 0.5 + 1e-9, turns
        assert math.remainder(session.pose().yaw - yaw - math.pi / 2, math.tau) == pytest.approx(0.0, abs=0.1)
    finally:
        assert params.set("behavior_server.max_rotational_vel", 1.0).successful
    result = params.set("behavior_server.max_rotational_vel", 7.0)
    assert not result.successful and "behavior_server.max_rotational_vel out of range Min: 0.0, Max: 6.0" in \
        result.reason, result.reason
    assert params.get("behavior_server.max_rotational_vel") == 1.0


@pytest.mark.parametrize("value, why", [
    (math.nan, "nan"), (math.inf, "inf"), (-math.inf, "-inf"), (-0.1, "-0.1"), (0.0, "must be in (0, 2], got 0.0"),
    ("fast", "expected a number, got 'fast'"), (True, "expected a number, got True"),
])
def test_a_bad_value_is_refused_naming_the_parameter_and_the_value_and_the_old_value_stays(session, value, why):
    result = session.params.set(MAX_VEL_X, value)
    assert not result.successful
    assert MAX_VEL_X in result.reason and why in result.reason, result.reason
    session.run_for(0.1, wall_timeout_s=WALL_GUARD_S)
    assert session.params.get(MAX_VEL_X) == 0.4
    assert session.move_base.controller.planner.cfg.robot.max_vel_x == 0.4


@pytest.mark.parametrize("name, value, why", [
    ("TebLocalPlannerROS.global_plan_viapoint_sep", math.nan, "expected a number (finite), got nan"),   # no range
    ("TebLocalPlannerROS.min_samples", 3.5, "expected an integer, got 3.5"),
    ("local_costmap.obstacles.front_laser.marking", "yes", "expected true or false, got 'yes'"),
])
def test_a_value_of_the_wrong_kind_is_refused_by_the_parameter_layer(session, name, value, why):
    before = session.params.get(name)
    result = session.params.set(name, value)
    assert not result.successful and result.reason == f"{name}: {why}"
    assert session.params.get(name) == before


def test_a_change_that_breaks_a_relation_between_parameters_is_refused(session):
    result = session.params.set("TebLocalPlannerROS.max_samples", 2)
    assert not result.successful and "must be >= min_samples (3)" in result.reason
    assert session.params.get("TebLocalPlannerROS.max_samples") == 500


@pytest.mark.parametrize("name, value", [
    ("TebLocalPlannerROS.footprint_model.type", "circular"),
    ("TebLocalPlannerROS.footprint_model.front_radius", 0.3),
    ("local_costmap.global_frame", "map"),
    ("local_costmap.robot_base_frame", "base_footprint"),
    ("local_costmap.plugins", ["obstacles"]),
    ("local_costmap.obstacles.plugin", "costmap_2d::StaticLayer"),
    ("local_costmap.obstacles.observation_sources", "front_laser"),
    ("local_costmap.obstacles.front_laser.topic", "/scan"),
    ("base_local_planner", "dwa_local_planner/DWAPlannerROS"),
    ("TebLocalPlannerROS.odom_topic", "/odometry"),
    ("global_costmap.resolution", 0.1),
])
def test_a_parameter_read_only_at_start_up_is_refused_with_requires_restart(session, name, value):
    before = session.params.get(name)
    result = session.params.set(name, value)
    assert not result.successful and "requires restart" in result.reason and name in result.reason, result.reason
    assert session.params.get(name) == before


def test_a_parameter_without_effect_here_is_refused_saying_so(session):
    result = session.params.set("TebLocalPlannerROS.weight_shortest_path", 1.0)
    assert not result.successful and "has no effect here" in result.reason, result.reason
    assert session.params.get("TebLocalPlannerROS.weight_shortest_path") == 0.0


@pytest.mark.parametrize("name, value", [("TebLocalPlannerROS.oscillation_filter_duration", 4.0),
                                         ("TebLocalPlannerROS.weight_prefer_rotdir", 20.0)])
def test_the_oscillation_recovery_takes_live_changes(session, name, value):
    result = session.params.set(name, value)
    assert result.successful, result.reason
    assert session.params.get(name) == value


def test_a_parameter_another_one_overrides_is_refused_saying_so(session):
    result = session.params.set("local_costmap.robot_radius", 0.6)
    assert not result.successful and "another parameter takes precedence" in result.reason, result.reason
    assert session.params.get("local_costmap.robot_radius") == 0.46


def test_controller_frequency_changes_the_control_rate(session, driving):
    params, node = session.params, session.move_base

    def cycles(seconds: float) -> int:
        t0 = session.time
        session.run_for(seconds, wall_timeout_s=WALL_GUARD_S)
        return len(params.commands_since(t0 + 1e-6))

    assert 19 <= cycles(1.0) <= 21                              # 20 Hz
    try:
        assert params.set("controller_frequency", 10).successful   # an int, as `ros2 param set ... 10` sends it
        assert params.get("controller_frequency") == 10.0        # stored as the float it is
        session.run_for(0.15, wall_timeout_s=WALL_GUARD_S)
        assert 9 <= cycles(1.0) <= 11                            # 10 Hz
        assert node.period == 0.1 and node.controller.planner.controller_period == 0.1
        assert node.controller._publish_timer.timer_period_ns == 100_000_000
    finally:
        assert params.set("controller_frequency", 20.0).successful
    session.run_for(0.15, wall_timeout_s=WALL_GUARD_S)
    assert 19 <= cycles(1.0) <= 21


def test_costmap_rates_and_layers_follow_their_parameters(session):
    params, local = session.params, session.move_base.local_costmap
    inflation = local.cm.layer("inflation_layer")
    front = local.cm.observation_buffer("front_laser").source
    changes = {"local_costmap.update_frequency": 5.0, "local_costmap.inflation_layer.inflation_radius": 0.6,
               "local_costmap.inflation_layer.cost_scaling_factor": 4.0,
               "local_costmap.obstacles.front_laser.obstacle_range": 4.0,
               "local_costmap.obstacles.front_laser.raytrace_range": 5.0}
    before = {name: params.get(name) for name in changes}
    try:
        for name, value in changes.items():
            assert params.set(name, value).successful, name
        session.run_for(0.2, wall_timeout_s=WALL_GUARD_S)
        assert local._update_timer.timer_period_ns == 200_000_000
        assert (inflation.inflation_radius, inflation.cost_scaling_factor) == (0.6, 4.0)
        assert (front.obstacle_range, front.raytrace_range) == (4.0, 5.0)
    finally:
        for name, value in before.items():
            assert params.set(name, value).successful, name
    session.run_for(0.2, wall_timeout_s=WALL_GUARD_S)
    assert local._update_timer.timer_period_ns == 100_000_000 and inflation.inflation_radius == 1.5


def test_describe_parameters_gives_each_parameter_its_description_and_range(session):
    max_vel_x, inflation, plugin, frame = session.params.describe(
        [MAX_VEL_X, "local_costmap.inflation_layer.inflation_radius", "local_costmap.obstacles.plugin",
         "local_costmap.global_frame"])
    assert max_vel_x.description == "maximum forward speed [m/s] (in (0, 2])"
    assert [(r.from_value, r.to_value) for r in max_vel_x.floating_point_range] == [(0.0, 2.0)]
    assert inflation.description.startswith("distance up to which obstacle cost is inflated [m] (>= 0)")
    assert [r.from_value for r in inflation.floating_point_range] == [0.0]
    assert plugin.description.endswith("requires restart") and frame.description.endswith("requires restart")
    node = session.move_base
    undescribed = [name for name in node.get_parameters_by_prefix("")
                   if name not in NODE_LEVEL
                   and not node.describe_parameter(name).description]
    assert undescribed == []


# -- every parameter a running move_base lets change reaches the object that uses it -------------------------

def _another_value(spec, value):
    """A valid value different from ``value``."""
    if spec.kind is bool:
        return not value
    if spec.kind is int:
        return value + 1 if spec.high is None or value + 1 <= spec.high else value - 1
    if spec.kind is float:
        new = value + 0.1 * max(abs(value), 1.0)
        return new if spec.high is None or new <= spec.high else (value + (spec.low or 0.0)) / 2
    if spec.name == "affected_maps":
        return "local" if value != "local" else "both"
    if spec.name == "footprint":
        return str((parse_footprint(value, "footprint") * 1.1).round(3).tolist())
    raise AssertionError(f"no other value for {spec.name} = {value!r}")


def _running_value(node, name: str):
    """What the running objects use for a parameter, by its ROS 2 name."""
    first, *rest = name.split(".")
    if not rest:
        return getattr(node.cfg, first)
    if first == "TebLocalPlannerROS":
        return value_of(node.controller.planner.cfg, rest[0])
    if first == "MPPILocalPlannerROS":            # the crowd planner (docs/design.md §7.1)
        return value_of(node.crowd_controller.planner.cfg, rest[0])
    if first == "GlobalPlanner":
        return getattr(node.planner.planner.config, rest[0])
    if first == "obstacle_tracking":
        return getattr(node.obstacle_tracking.tracker.params, rest[0])
    if first == "behavior_server":
        return getattr(node.behavior_server, rest[0])
    if first in node.recovery_instances:
        return getattr(node.recovery_instances[first], {"invert_area_to_clear": "invert_area"}.get(rest[0], rest[0]))
    costmap = getattr(node, first)
    if len(rest) == 1:
        if rest[0] == "footprint":
            return str(costmap.cm.unpadded_footprint.round(3).tolist())
        return getattr(costmap.config, rest[0])
    layer = costmap.cm.layer(rest[0])
    if len(rest) == 2:
        return getattr(layer, rest[1])
    return getattr(layer.buffers[rest[1]].source, rest[2])


def test_every_parameter_that_may_change_while_running_reaches_the_running_objects(session):
    node = session.move_base
    table = node.live_parameters.table
    current = {name: p.value for name, p in node.get_parameters_by_prefix("").items()}
    shadowed = ("global_costmap.robot_radius", "local_costmap.robot_radius")    # the lab gives a footprint
    live = {name: spec for name, spec in table.items()
            if name in current and spec.dynamic and spec.implemented and name not in shadowed}
    assert len(live) > 150
    changes = {name: _another_value(spec, current[name]) for name, spec in live.items()}
    try:
        result = node.set_parameters_atomically([Parameter(name, value=value) for name, value in changes.items()])
        assert result.successful, result.reason
        session.run_for(0.1, wall_timeout_s=WALL_GUARD_S)
        wrong = {name: (value, _running_value(node, name)) for name, value in changes.items()
                 if not np.all(_running_value(node, name) == value)}
        assert wrong == {}
        local = node.local_costmap      # the local planner's feasibility check uses the new footprint too
        np.testing.assert_array_equal(node.controller.planner.costmap_footprint, local.footprint)
    finally:
        assert node.set_parameters_atomically([Parameter(name, value=current[name]) for name in changes]).successful
    session.run_for(0.1, wall_timeout_s=WALL_GUARD_S)
    assert node.controller.planner.cfg.robot.max_vel_x == 0.4 and node.period == 0.05


# -- the costmap takes a change (unit level) -----------------------------------------------------------------

def _cost_beside_an_obstacle(costmap: CostmapCore, distance: float) -> int:
    """Cost ``distance`` metres beside a lethal point 1 m ahead of the robot at the origin."""
    costmap.add_point_cloud("front_laser", [[1.0, 0.0, 0.1]], (0.0, 0.0, 0.1), stamp=0.0)
    costmap.update_map(0.0, 0.0, 0.0)
    return int(costmap.costmap.costmap[costmap.costmap.world_to_map(1.0, distance)[::-1]])


def test_an_inflation_change_changes_the_cost_around_an_obstacle():
    tree = move_base_tree()
    costmap = CostmapCore("local_costmap", tree["local_costmap"], parents=[("move_base", tree)])
    live = LiveParameters(tree)
    assert lookup(live.table, "local_costmap.inflation_layer.inflation_radius").dynamic
    before = _cost_beside_an_obstacle(costmap, 0.6)
    assert before > 0                                    # inflation_radius 1.5 m reaches 0.6 m
    live.change([("local_costmap.inflation_layer.inflation_radius", 0.5)])
    costmap.reconfigure(live.take().configs.costmaps["local_costmap"])
    assert _cost_beside_an_obstacle(costmap, 0.6) == 0    # 0.5 m does not
    assert _cost_beside_an_obstacle(costmap, 0.45) > 0
    live.change([("local_costmap.inflation_layer.inflation_radius", 1.5),
                 ("local_costmap.inflation_layer.cost_scaling_factor", 2.0)])
    costmap.reconfigure(live.take().configs.costmaps["local_costmap"])
    assert _cost_beside_an_obstacle(costmap, 0.6) > before   # a slower decay: more cost at the same distance


@pytest.mark.parametrize("name, value, why", [
    ("local_costmap.footprint", "robot", "cannot parse footprint string 'robot'"),
    ("local_costmap.footprint", "[[0, 0], [1, 1]]", "needs at least three points"),
    ("local_costmap.footprint", "[[0, 0], [nan, 1], [1, 0]]", "cannot parse footprint string"),
    ("local_costmap.footprint", "[[0.1, 0.1], [0.1, 0.1], [0.1, 0.1]]", "repeats a point"),
    ("local_costmap.footprint", "[[0, 0], [0.2, 0.2], [0.4, 0.4]]", "lie on one line"),
    ("local_costmap.footprint", "[[0, 0], [0.3, 0.3], [0.3, 0], [0, 0.3]]", "cross (not a simple polygon)"),
    ("local_costmap.footprint", "[[0, 0], [1e308, 0], [0, 1]]", "more than 5 m from the base frame"),
    ("local_costmap.footprint", str([[math.cos(a) * 0.3, math.sin(a) * 0.3]
                                     for a in np.linspace(0, 2 * math.pi, 100, endpoint=False)]), "at most 64 points"),
    ("local_costmap.inflation_layer.inflation_radius", 1e6, "more than the costmap's diagonal"),
    ("controller_frequency", 1e308, "Parameter controller_frequency out of range Min: 0.5, Max: 100.0"),
    ("controller_frequency", 1e-300, "Parameter controller_frequency out of range Min: 0.5, Max: 100.0"),
    ("controller_frequency", 1e-6, "Parameter controller_frequency out of range Min: 0.5, Max: 100.0"),
    ("local_costmap.inflation_layer.inflaton_radius", 1.0, "'local_costmap.inflation_layer.inflaton_radius' is not "
     "a parameter of /move_base (did you mean 'local_costmap.inflation_layer.inflation_radius'?)"),
])
def test_a_hostile_value_is_refused_with_the_reason_and_move_base_drives_on(session, name, value, why):
    """What once killed move_base or stalled its loop (probes of a running launch): a refusal that says why,
    and the next goal is driven as before."""
    result = session.params.set(name, value)
    assert not result.successful and why in result.reason, result.reason
    run = session.send_goal(Pose2D(session.pose().x + 0.5, 0.0, 0.0, "half a metre on"))
    session.run_for(30.0, lambda: run.done, wall_timeout_s=WALL_GUARD_S)
    assert run.status == "SUCCEEDED", (run.status, run.reason)
