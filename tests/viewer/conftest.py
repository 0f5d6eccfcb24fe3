"""A small scenario for the viewer: the simulator between two walls, plus move_base's outputs faked.

The costmap and plans are fixed, so the page's pixels can be checked against exact
positions; the simulator is real (scans, TF, odometry, robot description).
"""

import threading
import time

import numpy as np
import pytest
from actionlib_msgs.msg import GoalStatus, GoalStatusArray
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter


from simplebot_navigation.costmap.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from simplebot_navigation.ros.conversions import occupancy_grid_msg, path_msg, pose_array_msg, xyyaw_to_pose
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.ros.simulator.simulator_node import SimulatorNode
from simplebot_navigation.viewer.node import ViewerNode

FRONT_WALL_X = 2.2   # near face of the wall ahead of the robot (robot at the origin, facing +x)
BACK_WALL_X = -2.4   # near face of the wall behind it
RESOLUTION = 0.05
ORIGIN = (-5.0, -5.0)
LETHAL_BLOCK = (-2.0, -3.0, -1.5, -2.5)      # x0, y0, x1, y1: lethal cells
INSCRIBED_BLOCK = (-2.0, 2.0, -1.5, 2.5)
UNKNOWN_BLOCK = (3.0, 3.0, 4.0, 4.0)
CART_SIZE, CART_Y = (0.4, 0.6), -7.0
PLAN = np.array([[0.0, 0.0, 0.0], [0.5, -0.5, -0.785], [1.0, -1.0, -0.785], [1.5, -1.5, -0.785]])


def cells(block):
    x0, y0, x1, y1 = block
    return (slice(round((y0 - ORIGIN[1]) / RESOLUTION), round((y1 - ORIGIN[1]) / RESOLUTION)),
            slice(round((x0 - ORIGIN[0]) / RESOLUTION), round((x1 - ORIGIN[0]) / RESOLUTION)))


def costmap_array() -> np.ndarray:
    costs = np.zeros((200, 200), dtype=np.uint8)
    costs[cells(LETHAL_BLOCK)] = LETHAL_OBSTACLE
    costs[cells(INSCRIBED_BLOCK)] = INSCRIBED_INFLATED_OBSTACLE
    costs[cells(UNKNOWN_BLOCK)] = NO_INFORMATION
    return costs


class FakeMoveBase(Node):
    """Publishes what move_base would (a global costmap, plans, goal, status); records goals it is sent."""

    def __init__(self, context):
        super().__init__("fake_move_base", context=context)
        self.goals: list[PoseStamped] = []
        self.create_subscription(PoseStamped, "/move_base_simple/goal", self.goals.append, 10)
        #: what a localizer would receive from a 2D Pose Estimate
        self.initial_poses: list[PoseWithCovarianceStamped] = []
        self.create_subscription(PoseWithCovarianceStamped, "/initialpose", self.initial_poses.append, 10)
        stamp = self.get_clock().now().to_msg()
        self.costmap_pub = self.create_publisher(OccupancyGrid, "/global_costmap/costmap", LATCHED)
        self.costmap_pub.publish(occupancy_grid_msg(costmap_array(), RESOLUTION, *ORIGIN, "odom", stamp))
        self.plan_pub = self.create_publisher(type(path_msg(PLAN, "odom", stamp)), "/move_base/GlobalPlanner/plan", 1)
        self.local_pub = self.create_publisher(type(path_msg(PLAN, "odom", stamp)),
                                               "/move_base/TebLocalPlannerROS/local_plan", 1)
        self.teb_pub = self.create_publisher(type(pose_array_msg(PLAN, "odom", stamp)),
                                             "/move_base/TebLocalPlannerROS/teb_poses", 1)
        self.goal_pub = self.create_publisher(PoseStamped, "/move_base/current_goal", 1)
        self.status_pub = self.create_publisher(GoalStatusArray, "/move_base/status", 1)
        self.create_timer(0.1, self.publish)

    def publish(self) -> None:
        stamp = self.get_clock().now().to_msg()
        self.plan_pub.publish(path_msg(PLAN, "odom", stamp))
        self.local_pub.publish(path_msg(PLAN[:2], "odom", stamp))
        self.teb_pub.publish(pose_array_msg(PLAN[:2], "odom", stamp))
        goal = PoseStamped()
        goal.header.frame_id, goal.header.stamp = "odom", stamp
        goal.pose = xyyaw_to_pose(*PLAN[-1])
        self.goal_pub.publish(goal)
        status = GoalStatusArray()
        status.status_list = [GoalStatus(status=GoalStatus.ACTIVE, text="following the plan")]
        self.status_pub.publish(status)


class Scenario:
    def __init__(self, context, world: str):
        self.sim = SimulatorNode(context=context, parameter_overrides=[
            Parameter("world", value=world), Parameter("real_time_factor", value=1.0)])
        self.move_base = FakeMoveBase(context)
        self.viewer = ViewerNode(context=context, parameter_overrides=[Parameter("port", value=0)])
        self.executor = SingleThreadedExecutor(context=context)
        for node in (self.sim, self.move_base, self.viewer):
            self.executor.add_node(node)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self._stop = threading.Event()
        self.thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def wait_for(self, done, timeout=10.0, what="condition"):
        deadline = time.monotonic() + timeout
        while not done():
            assert time.monotonic() < deadline, f"timed out waiting for {what}"
            time.sleep(0.02)

    def close(self) -> None:
        self._stop.set()
        self.thread.join(timeout=5.0)
        self.executor.shutdown()
        for node in (self.viewer, self.move_base, self.sim):
            node.destroy_node()


@pytest.fixture(scope="module")
def corridor(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("worlds") / "corridor.yaml"
    front, back = FRONT_WALL_X + 0.05, BACK_WALL_X - 0.05
    path.write_text(
        "name: corridor\n"
        f"walls: [{{from: [{front}, -3.0], to: [{front}, 3.0], thickness: 0.1, height: 1.0}},\n"
        f"        {{from: [{back}, -3.0], to: [{back}, 3.0], thickness: 0.1, height: 1.0}}]\n"
        "boxes: []\ncylinders: []\nstart: {x: 0.0, y: 0.0, yaw: 0.0}\n"
        # a cart creeping along out of the lidars' reach (5.6 m), for the moving obstacles' layer
        f"moving: [{{shape: box, size: [{CART_SIZE[0]}, {CART_SIZE[1]}], "
        f"keyframes: [[0, -1.0, {CART_Y}], [1000, 1.0, {CART_Y}]]}}]\n")
    return str(path)


@pytest.fixture(scope="module")
def scenario(context, corridor):
    running = Scenario(context, corridor)
    yield running
    running.close()
