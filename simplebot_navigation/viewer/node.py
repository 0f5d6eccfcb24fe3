"""The viewer node: subscribes to what the lab shows in RViz and serves it to a browser page.

Callbacks only copy message contents into a Scene; the HTTP server (own threads)
encodes frames at a bounded rate. The page's 2D Nav Goal comes back as a POST and
is published as a PoseStamped on /move_base_simple/goal in the fixed frame; its 2D Pose Estimate as a
PoseWithCovarianceStamped on /initialpose, as RViz's tools do.

The topics are subscribed only while a page is open: taking ~150 messages a second
costs a Python process a sixth of a core, which the navigation nodes need more
when nobody is looking. Costmaps arrive whole again on subscribing (latched).
"""

from __future__ import annotations

import io
import math
import sys
import time

import numpy as np
import yourdfpy
from actionlib_msgs.msg import GoalStatus, GoalStatusArray
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, PoseArray, PoseStamped, PoseWithCovarianceStamped, Twist
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from rcl_interfaces.msg import Log
from rclpy.clock import Clock, ClockType
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.time import Time
from scipy.spatial import ConvexHull
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from simplebot_navigation.ros.conversions import path_to_array, pose_to_xyyaw, transform_to_xyyaw, xyyaw_to_pose
from simplebot_navigation.ros.move_base.move_base_stats import NAVIGATION_STATUS
from simplebot_navigation.ros.node_main import SetUpNode, run_node
from simplebot_navigation.parameters.spec import Param
from simplebot_navigation.ros.params import declare_specs, take_live_changes
from simplebot_navigation.ros.qos import LATCHED
from simplebot_navigation.ros.tf import Buffer, TransformException, TransformListener, strip_frame
from simplebot_navigation.viewer.scene import Scene, obstacle_outlines
from simplebot_navigation.viewer.server import ViewerServer

UPDATES = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
ROSOUT = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)

COSTMAPS = {"global_costmap": "/global_costmap", "local_costmap": "/local_costmap"}
SCANS = {"front_scan": "/front_laser/front_scan", "back_scan": "/back_laser/back_scan"}
PATHS = {"global_plan": "/move_base/GlobalPlanner/plan",
         "local_plan": "/move_base/TebLocalPlannerROS/local_plan"}
TEB_POSES = "/move_base/TebLocalPlannerROS/teb_poses"
FOOTPRINT = "/local_costmap/footprint"
CURRENT_GOAL = "/move_base/current_goal"
STATUS = "/move_base/status"
ODOM = "/simplebot_controller/odom"
CMD_VEL = "/simplebot_controller/cmd_vel"
GOAL = "/move_base_simple/goal"
INITIAL_POSE = "/initialpose"
#: the spread a 2D Pose Estimate gives the localizer, as RViz's tool: 0.5 m and 15 deg standard deviations
INITIAL_POSE_VARIANCES = (0.25, 0.25, (math.pi / 12.0) ** 2)
DIAGNOSTICS = "/diagnostics"
MOVING_OBSTACLES = "/sim/moving_obstacles"

LABEL = "viewer parameter"
PARAMETERS = {
    "host": Param(str, "127.0.0.1", "", "address the HTTP server listens on", dynamic=False),
    "port": Param(int, 8765, "", "port of the HTTP server (0: a free one)", low=0, high=65535, dynamic=False),
    "fixed_frame": Param(str, "odom", "", "the frame the page draws in", dynamic=False),
    "base_frame": Param(str, "base_link", "", "the robot's frame (its body and footprint)", dynamic=False),
    "rate": Param(float, 20.0, "Hz", "frames a second sent to the pages, at most", low=0.1, high=60.0),
    "costmap_rate": Param(float, 5.0, "Hz", "costmap images a second sent to the pages, at most", low=0.1,
                          high=60.0),
    "max_costmap_side": Param(int, 400, "cells", "a costmap is sent downsampled to at most this many cells a side",
                              low=16, high=4096),
    "trail_points": Param(int, 5000, "", "points of the robot's trail kept (then thinned to half)", low=2,
                          high=100_000),
}
STATUS_NAMES = {getattr(GoalStatus, n): n for n in ("PENDING", "ACTIVE", "PREEMPTED", "SUCCEEDED", "ABORTED",
                                                    "REJECTED", "PREEMPTING", "RECALLING", "RECALLED", "LOST")}
LOG_LEVELS = {10: "DEBUG", 20: "INFO", 30: "WARN", 40: "ERROR", 50: "FATAL"}
CIRCLE_POINTS = 24
PAGE_CHECK_S = 0.25   # how often the node looks whether a page is open
PAGE_GONE_S = 10.0    # no frame request for this long: the page is closed


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def body_outlines(urdf: str, base_frame: str = "base_link") -> list[np.ndarray]:
    """Top views of the robot's visual boxes, cylinders and spheres in base_frame, lowest first.

    Each outline is the convex hull of the shape's points projected to the floor, so a
    wheel (a cylinder on its side) shows as its rectangle and the round body as a disc.
    """
    robot = yourdfpy.URDF.load(io.StringIO(urdf), build_scene_graph=True, load_meshes=False)
    shapes = []
    ring = np.linspace(0.0, 2.0 * math.pi, CIRCLE_POINTS, endpoint=False)
    for name, link in robot.link_map.items():
        if not link.visuals:
            continue
        link_pose = robot.get_transform(name, base_frame)
        for visual in link.visuals:
            g = visual.geometry
            if g.box is not None:
                half = np.asarray(g.box.size, float) / 2.0
                points = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
            elif g.cylinder is not None:
                r, h = g.cylinder.radius, g.cylinder.length / 2.0
                disc = np.stack([r * np.cos(ring), r * np.sin(ring)], axis=1)
                points = np.vstack([np.column_stack([disc, np.full(len(ring), z)]) for z in (-h, h)])
            elif g.sphere is not None:
                r = g.sphere.radius
                points = np.column_stack([r * np.cos(ring), r * np.sin(ring), np.zeros(len(ring))])
            else:
                continue  # meshes: the footprint still shows where the robot is
            pose = link_pose @ (visual.origin if visual.origin is not None else np.eye(4))
            world = points @ pose[:3, :3].T + pose[:3, 3]
            xy = world[:, :2]
            hull = ConvexHull(xy)
            shapes.append((float(world[:, 2].max()), xy[hull.vertices]))
    return [outline for _, outline in sorted(shapes, key=lambda s: s[0])]


class ViewerNode(SetUpNode):
    def __init__(self, **kwargs):
        super().__init__("viewer", **kwargs)

    def _set_up(self) -> None:
        p = self._checked_parameters()
        self.fixed_frame = strip_frame(p["fixed_frame"])
        self.base_frame = strip_frame(p["base_frame"])
        self.scene = Scene(self.fixed_frame, max_costmap_side=p["max_costmap_side"],
                           costmap_period_s=1.0 / p["costmap_rate"], trail_points=p["trail_points"])
        self.tf = Buffer(node=self)
        self.listener: TransformListener | None = None
        self._live: list = []
        self.goal_pub = self.create_publisher(PoseStamped, GOAL, 1)
        self.initial_pose_pub = self.create_publisher(PoseWithCovarianceStamped, INITIAL_POSE, 1)
        self.create_subscription(String, "/robot_description", self._on_description, LATCHED)
        try:
            self.server = ViewerServer(self.scene, self._lookup, self.publish_goal, host=p["host"], port=p["port"],
                                       rate=p["rate"], base_frame=self.base_frame,
                                       on_initial_pose=self.publish_initial_pose)
        except OSError as err:
            raise OSError(f"viewer cannot listen on {p['host']}:{p['port']}: {err.strerror or err} "
                          "(set the 'port' parameter, 0 picks a free one)") from err
        self.server.start()
        take_live_changes(self, PARAMETERS, LABEL, self._take_parameters)
        self.create_timer(PAGE_CHECK_S, self._follow_pages, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f"viewer on {self.server.url} (fixed frame {self.fixed_frame})")

    @property
    def url(self) -> str:
        return self.server.url

    def _checked_parameters(self) -> dict:
        values = declare_specs(self, PARAMETERS, LABEL)
        for name in ("fixed_frame", "base_frame"):
            if not strip_frame(values[name]):
                raise ValueError(f"{LABEL} {name!r}: expected a frame name, got {values[name]!r}")
        return values

    def _take_parameters(self, changes: dict) -> None:
        """The rates and sizes change while running (the costmap's size with its next image)."""
        for name, value in changes.items():
            if name == "rate":
                self.server.period_s = 1.0 / value
            elif name == "costmap_rate":
                self.scene.costmap_period_s = 1.0 / value
            else:
                setattr(self.scene, name, value)

    @property
    def watched(self) -> bool:
        """Whether the topics are subscribed (a page asked for a frame lately)."""
        return self.listener is not None

    def _follow_pages(self) -> None:
        page_open = time.monotonic() - self.server.last_request < PAGE_GONE_S
        if page_open and not self.watched:
            self._subscribe()
        elif not page_open and self.watched:
            self._unsubscribe()

    def _subscribe(self) -> None:
        scene = self.scene
        self.listener = TransformListener(self.tf, self)
        sub = self.create_subscription
        live = self._live
        for name, ns in COSTMAPS.items():
            live.append(sub(OccupancyGrid, f"{ns}/costmap", lambda m, n=name: self._on_grid(n, m), LATCHED))
            live.append(sub(OccupancyGridUpdate, f"{ns}/costmap_updates",
                            lambda m, n=name: self._on_grid_update(n, m), UPDATES))
        for name, topic in SCANS.items():
            live.append(sub(LaserScan, topic, lambda m, n=name: scene.set_scan(
                n, strip_frame(m.header.frame_id), _stamp_ns(m.header.stamp), m.angle_min, m.angle_increment,
                np.asarray(m.ranges, dtype=np.float32), m.range_min, m.range_max), qos_profile_sensor_data))
        for name, topic in PATHS.items():
            live.append(sub(Path, topic, lambda m, n=name: scene.set_poses(
                n, strip_frame(m.header.frame_id), _stamp_ns(m.header.stamp), path_to_array(m)), 1))
        live.append(sub(PoseArray, TEB_POSES, lambda m: scene.set_poses(
            "teb_poses", strip_frame(m.header.frame_id), _stamp_ns(m.header.stamp),
            np.array([pose_to_xyyaw(p) for p in m.poses], dtype=float).reshape(-1, 3)), 1))
        live.append(sub(PolygonStamped, FOOTPRINT, lambda m: scene.set_poses(
            "footprint", strip_frame(m.header.frame_id), _stamp_ns(m.header.stamp),
            np.array([(p.x, p.y) for p in m.polygon.points], dtype=float).reshape(-1, 2)), 1))
        live.append(sub(PoseStamped, CURRENT_GOAL, lambda m: scene.set_goal(
            strip_frame(m.header.frame_id), _stamp_ns(m.header.stamp), pose_to_xyyaw(m.pose)), 1))
        live.append(sub(GoalStatusArray, STATUS, self._on_status, 10))
        live.append(sub(Odometry, ODOM, self._on_odom, 10))
        live.append(sub(Twist, CMD_VEL, lambda m: scene.set_command(m.linear.x, m.angular.z), 10))
        live.append(sub(Log, "/rosout", self._on_log, ROSOUT))
        live.append(sub(DiagnosticArray, DIAGNOSTICS, self._on_diagnostics, 10))
        live.append(sub(MarkerArray, MOVING_OBSTACLES, self._on_moving_obstacles, 1))

    def _unsubscribe(self) -> None:
        self.listener.unregister()
        self.listener = None
        for subscription in self._live:
            self.destroy_subscription(subscription)
        self._live.clear()

    # -- callbacks --------------------------------------------------------------------------------
    def _on_moving_obstacles(self, msg: MarkerArray) -> None:
        bodies = [m for m in msg.markers if m.ns == "moving_obstacles"]
        if bodies:
            shapes = [(m.type == Marker.CYLINDER, *pose_to_xyyaw(m.pose), m.scale.x, m.scale.y) for m in bodies]
            self.scene.set_poses("moving_obstacles", strip_frame(bodies[0].header.frame_id),
                                 _stamp_ns(bodies[0].header.stamp), obstacle_outlines(shapes))

    def _on_grid(self, name: str, msg: OccupancyGrid) -> None:
        info = msg.info
        cells = np.asarray(msg.data, dtype=np.int8)
        if cells.size != info.width * info.height:
            self.get_logger().warn(f"{COSTMAPS[name]}/costmap: {cells.size} cells for a {info.width}x{info.height} "
                                   "grid; not drawn", throttle_duration_sec=5.0)
            return
        origin = pose_to_xyyaw(info.origin)
        self.scene.set_grid(name, cells.reshape(info.height, info.width), info.resolution, origin,
                            strip_frame(msg.header.frame_id))

    def _on_grid_update(self, name: str, msg: OccupancyGridUpdate) -> None:
        cells = np.asarray(msg.data, dtype=np.int8)
        if cells.size != msg.width * msg.height:
            self.get_logger().warn(f"{COSTMAPS[name]}/costmap_updates: {cells.size} cells for a "
                                   f"{msg.width}x{msg.height} window; not drawn", throttle_duration_sec=5.0)
            return
        try:
            self.scene.update_grid(name, msg.x, msg.y, cells.reshape(msg.height, msg.width))
        except ValueError as err:
            self.get_logger().warn(str(err), throttle_duration_sec=5.0)

    def _on_odom(self, msg: Odometry) -> None:
        # Sim time and the real-time factor come from the odometry stamps: a /clock subscription
        # would add 100 messages a second for a number the panel shows to a tenth of a second.
        self.scene.set_clock(_stamp_ns(msg.header.stamp) / 1e9)
        x, y, _ = pose_to_xyyaw(msg.pose.pose)
        frame = strip_frame(msg.header.frame_id)
        if frame != self.fixed_frame:
            placed = self._lookup(frame, 0)
            if placed is None:
                return
            c, s = math.cos(placed[2]), math.sin(placed[2])
            x, y = placed[0] + c * x - s * y, placed[1] + s * x + c * y
        self.scene.set_odometry(x, y, msg.twist.twist.linear.x, msg.twist.twist.angular.z)

    def _on_status(self, msg: GoalStatusArray) -> None:
        if not msg.status_list:
            self.scene.set_status({"state": "idle", "goals": 0})
            return
        last = msg.status_list[-1]
        self.scene.set_status({"state": STATUS_NAMES.get(last.status, str(last.status)), "text": last.text,
                               "goal_id": last.goal_id.id, "goals": len(msg.status_list)})

    def _on_description(self, msg: String) -> None:
        try:
            self.scene.set_body(body_outlines(msg.data, self.base_frame))
        except Exception as err:  # noqa: BLE001 - any unreadable URDF: say so, keep the footprint view
            self.get_logger().warn(f"/robot_description: cannot draw the robot body: {err}")

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name == NAVIGATION_STATUS:
                values = {kv.key: kv.value for kv in status.values}
                self.scene.set_recoveries(int(values.get("recoveries", 0)), values.get("last_recovery") or None)

    def _on_log(self, msg: Log) -> None:
        if msg.level >= 20 and msg.name != self.get_logger().name:
            self.scene.add_log(LOG_LEVELS.get(msg.level, str(msg.level)), msg.name, msg.msg)

    # -- used by the server threads ---------------------------------------------------------------
    def _lookup(self, frame: str, stamp_ns: int):
        if frame == self.fixed_frame:
            return (0.0, 0.0, 0.0)
        try:
            tf = self.tf.lookup_transform(self.fixed_frame, frame, Time(nanoseconds=stamp_ns))
        except TransformException:
            if stamp_ns == 0:
                return None
            try:  # a scan older than the buffer or newer than the last transform: draw it where the robot is
                tf = self.tf.lookup_transform(self.fixed_frame, frame, Time())
            except TransformException:
                return None
        return transform_to_xyyaw(tf)

    def publish_goal(self, x: float, y: float, yaw: float) -> PoseStamped:
        msg = PoseStamped()
        msg.header.frame_id = self.fixed_frame
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.pose = xyyaw_to_pose(x, y, yaw)
        self.goal_pub.publish(msg)
        self.get_logger().info(f"2D Nav Goal: x {x:.3f}, y {y:.3f}, yaw {math.degrees(yaw):.1f} deg "
                               f"in {self.fixed_frame}")
        return msg

    def publish_initial_pose(self, x: float, y: float, yaw: float) -> PoseWithCovarianceStamped:
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = self.fixed_frame
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.pose.pose = xyyaw_to_pose(x, y, yaw)
        covariance = [0.0] * 36
        covariance[0], covariance[7], covariance[35] = INITIAL_POSE_VARIANCES
        msg.pose.covariance = covariance
        self.initial_pose_pub.publish(msg)
        self.get_logger().info(f"2D Pose Estimate: x {x:.3f}, y {y:.3f}, yaw {math.degrees(yaw):.1f} deg "
                               f"in {self.fixed_frame}")
        return msg

    def destroy_node(self) -> None:
        server = getattr(self, "server", None)
        if server is not None:
            server.stop()
        super().destroy_node()


def main(args=None) -> int:
    return run_node("viewer", ViewerNode, args, (ValueError, OSError))

if __name__ == "__main__":
    sys.exit(main())
