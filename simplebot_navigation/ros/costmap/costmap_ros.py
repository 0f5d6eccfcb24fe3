"""Costmap2DROS: the ROS shell around a `Costmap`, living inside the move_base node (docs/reference.md §2.2).

It reads `<name>.*` parameters of its node, waits for global_frame <- robot_base_frame, updates the
layers at update_frequency on the node's clock and hands publishing to a CostmapPublisher and
subscribing (sensors through a message filter, maps) to a CostmapInput. Planners read `costmap`
while holding `lock`.
"""

from __future__ import annotations

import math
import threading
import time
from typing import NamedTuple

import numpy as np
from geometry_msgs.msg import Polygon
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.time import Time

from simplebot_navigation.costmap.costmap_core import CostmapCore
from simplebot_navigation.costmap.costmap_2d import Costmap2D
from simplebot_navigation.costmap.params import parameter_specs
from simplebot_navigation.costmap.plugins import LAYERS
from simplebot_navigation.ros.conversions import stamp_seconds, yaw_of
from simplebot_navigation.ros.costmap.costmap_input import CostmapInput
from simplebot_navigation.log_throttle import Throttle
from simplebot_navigation.ros.costmap.costmap_log import prepare_process, speaking_for
from simplebot_navigation.ros.costmap.costmap_publisher import CostmapPublisher
from simplebot_navigation.ros.params import declare_defaults, given_parameter_tree
from simplebot_navigation.ros.tf import (Buffer, ConnectivityException, ExtrapolationException, LookupException,
                                         TransformException)

#: start-up: how often TF is tried, and how often the wait is reported (wall time)
TF_WAIT_POLL_S = 0.1
TF_WAIT_WARNING_PERIOD_S = 5.0


class RobotPose(NamedTuple):
    x: float
    y: float
    yaw: float
    stamp: Time


class Costmap2DROS:
    """One costmap of a node: `Costmap2DROS(node, 'local_costmap', tf_buffer)`. With an `obstacle_feed`
    (perception/feed.py) each update first clears where moving obstacles are and just were; a `scan_observer` is
    called with (source, LaserScan, sensor -> global transform) for every scan the costmap takes in."""

    def __init__(self, node: Node, name: str, tf_buffer: Buffer, callback_group=None, obstacle_feed=None,
                 scan_observer=None):
        self.node = node
        self.obstacle_feed = obstacle_feed
        self.scan_observer = scan_observer
        self.name = name
        self.tf = tf_buffer
        self.logger = node.get_logger()
        self.callback_group = callback_group
        self.lock = threading.RLock()
        self.throttle = Throttle()
        prepare_process()

        given = given_parameter_tree(node, name)
        parents = [(node.get_fully_qualified_name(), given_parameter_tree(node))]
        self.cm = CostmapCore(name, given, parents=parents, clock=self.now_s)
        self.config = self.cm.config
        for warning in self.cm.warnings:
            self.logger.warning(warning)
        declare_defaults(node, self._resolved_tree(given, parents), prefix=name, specs=parameter_specs(self.config))

        c = self.config
        self.global_frame = c.global_frame
        self.robot_base_frame = c.robot_base_frame
        self.transform_tolerance = c.transform_tolerance
        self.last_pose_error = ""
        self._active = False
        self._stopped = False
        #: global_frame <- robot_base_frame has been available; message drops are reported from then on
        self.tf_ready = False
        self._last_wait_warning = time.monotonic()
        self._last_publish_s = -math.inf

        self.publisher = CostmapPublisher(self, self._topic(c.published_footprint_topic))
        # costmap_2d subscribes geometry_msgs/Polygon on footprint_topic; under its default name that
        # topic is the published PolygonStamped one, which cannot carry both types, so it is skipped.
        self._footprint_sub = None
        if self._topic(c.footprint_topic) != self._topic(c.published_footprint_topic):
            self._footprint_sub = node.create_subscription(Polygon, self._topic(c.footprint_topic),
                                                           self._on_footprint, 1,
                                                           callback_group=callback_group)
        self.input = CostmapInput(self)
        self._tf_wait_timer = node.create_timer(TF_WAIT_POLL_S, self._wait_for_tf, callback_group=callback_group,
                                                clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._update_timer = None
        self._set_rates()
        # Subscribing now lets discovery run while TF is awaited; messages wait in the filter queues.
        self._activate()

    # -- parameters -------------------------------------------------------------------------------
    def _resolved_tree(self, given: dict, parents) -> dict:
        """The ROS 1 tree this costmap runs with, for declare_defaults (given values are kept)."""
        c = self.config
        tree = {key: getattr(c, key) for key in (
            "global_frame", "robot_base_frame", "rolling_window", "track_unknown_space",
            "always_send_full_costmap", "transform_tolerance", "update_frequency", "publish_frequency", "width",
            "height", "resolution", "origin_x", "origin_y", "footprint_padding", "footprint_topic",
            "published_footprint_topic")}
        searched = [given] + [values for _, values in parents]
        if not any("footprint" in ns for ns in searched):
            tree["footprint"] = "[]"
        if not any("robot_radius" in ns for ns in searched):
            tree["robot_radius"] = c.robot_radius
        tree["plugins"] = [{"name": p.name, "type": p.type} for p in c.plugins]
        for plugin in c.plugins:
            tree[plugin.name] = LAYERS.spec(plugin.kind).parameter_tree(plugin.params)
        return tree

    def reconfigure(self, config) -> list[str]:
        """A run-time change (CostmapCore.reconfigure): the layers take theirs, this shell its rates and
        tolerance. Returns the costmap-level names that changed."""
        with self.lock:
            changed = self.cm.reconfigure(config)
        self.transform_tolerance = self.config.transform_tolerance
        if {"update_frequency", "publish_frequency"} & set(changed):
            self._set_rates()
        return changed

    def _set_rates(self) -> None:
        """Update and publish periods from the configuration; update_frequency 0 stops the update timer."""
        c = self.config
        self._update_period = 1.0 / c.update_frequency if c.update_frequency > 0 else 0.0
        self._publish_period = 1.0 / c.publish_frequency if c.publish_frequency > 0 else 0.0
        timer = self._update_timer
        if self._update_period == 0:
            if timer is not None:
                timer.cancel()
        elif timer is None:
            self._update_timer = self.node.create_timer(self._update_period, self._update_cycle,
                                                        callback_group=self.callback_group)
        else:
            timer.timer_period_ns = round(self._update_period * 1e9)
            timer.reset()          # the next update one new period from now

    def _topic(self, topic: str) -> str:
        """A costmap-private topic: relative names live under <namespace>/<name>/ (docs/design.md §5)."""
        return topic if topic.startswith("/") else f"{self.name}/{topic}"

    def now_s(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    # -- start-up, start/stop ---------------------------------------------------------------------
    def _wait_for_tf(self) -> None:
        """Say every few seconds that global_frame <- robot_base_frame is missing; the ROS 1 constructor
        blocks here instead, which would stall the node's executor. Wall-clock, so it speaks even
        before /clock runs; the update cycle (sim time) is what starts updating, so that a lockstep
        run does not depend on how busy the machine is."""
        try:
            self.tf.lookup_transform(self.global_frame, self.robot_base_frame, Time())
        except TransformException as err:
            now = time.monotonic()
            if now - self._last_wait_warning >= TF_WAIT_WARNING_PERIOD_S:
                self._last_wait_warning = now
                self.logger.warning(
                    f"{self.name}: Timed out waiting for transform from {self.robot_base_frame} to "
                    f"{self.global_frame} to become available before running costmap, tf error: {err}")
            return
        self._tf_wait_timer.cancel()
        self.node.destroy_timer(self._tf_wait_timer)
        self._tf_wait_timer = None
        if self._update_period == 0:  # no update cycle would start the costmap
            self.tf_ready = True

    def _activate(self) -> None:
        """Subscribe every source (a sensor layer's activate, which also restarts their staleness clocks)."""
        if self._active:
            return
        self.input.subscribe()
        self._restart_staleness_clocks()
        self._active = True

    def _restart_staleness_clocks(self) -> None:
        now = self.now_s()
        with self.lock:
            self.cm.restart_staleness_clocks(now)

    def _deactivate(self) -> None:
        self.input.unsubscribe()
        self._active = False

    def start(self) -> None:
        """Re-subscribe after stop() (move_base restarts its costmaps on a new goal)."""
        self._stopped = False
        self._activate()

    def stop(self) -> None:
        """Unsubscribe every source and stop updating."""
        self._stopped = True
        self._deactivate()

    def destroy(self) -> None:
        """Release every subscription, timer and publisher (the node itself stays)."""
        self._deactivate()
        self.input.destroy()
        node = self.node
        for timer in (self._update_timer, self._tf_wait_timer):
            if timer is not None:
                node.destroy_timer(timer)
        if self._footprint_sub is not None:
            node.destroy_subscription(self._footprint_sub)
        self.publisher.destroy()

    def _on_footprint(self, msg: Polygon) -> None:
        points = [(p.x, p.y) for p in msg.points]
        if len(points) < 3:
            self.logger.error(f"{self.name}: a footprint needs at least 3 points, got {len(points)} on "
                              f"{self._topic(self.config.footprint_topic)}; keeping the current one")
            return
        with self.lock:
            self.cm.set_unpadded_footprint(points)

    # -- robot pose ----------------------------------------------------------------------------------
    def _lookup_robot_pose(self) -> tuple[RobotPose | None, str]:
        try:
            tf = self.tf.lookup_transform(self.global_frame, self.robot_base_frame, Time())
        except LookupException as err:
            return None, f"No Transform available Error looking up robot pose: {err}"
        except ConnectivityException as err:
            return None, f"Connectivity Error looking up robot pose: {err}"
        except ExtrapolationException as err:
            return None, f"Extrapolation Error looking up robot pose: {err}"
        except TransformException as err:
            return None, f"Error looking up robot pose: {err}"
        stamp = Time.from_msg(tf.header.stamp)
        now = self.now_s()
        if now - stamp_seconds(stamp) > self.transform_tolerance:
            return None, (f"Costmap2DROS transform timeout. Current time: {now:.4f}, global_pose stamp: "
                          f"{stamp_seconds(stamp):.4f}, tolerance: {self.transform_tolerance:.4f}")
        t = tf.transform.translation
        return RobotPose(t.x, t.y, yaw_of(tf.transform.rotation), stamp), ""

    def get_robot_pose(self) -> RobotPose | None:
        """Robot pose in global_frame from the latest TF, or None (reason in last_pose_error, logged
        at most once a second) when missing or older than transform_tolerance."""
        pose, reason = self._lookup_robot_pose()
        self.last_pose_error = reason
        if pose is not None or not self.throttle("pose", 1.0):
            return pose
        if reason.startswith("Costmap2DROS transform timeout"):
            self.logger.warning(f"{self.name}: {reason}")
        else:
            self.logger.error(f"{self.name}: {reason}")
        return None

    # -- update loop ---------------------------------------------------------------------------------
    def _update_cycle(self) -> None:
        if self._stopped:
            return
        if not self.tf_ready:
            if not self.tf.can_transform(self.global_frame, self.robot_base_frame, Time()):
                return
            self.tf_ready = True
        if not self.cm.initialized:
            # Sensors are judged from the first update on: before it, the wait for TF (and, under
            # use_sim_time, for /clock) is not their fault.
            self._restart_staleness_clocks()
        start = self.now_s()
        self.update_map_now()
        if (self._publish_period > 0 and self.cm.initialized
                and start - self._last_publish_s >= self._publish_period):
            self.publisher.publish_costmap()
            self._last_publish_s = start
        took = self.now_s() - start
        if took > self._update_period and self.throttle("rate", 1.0):
            self.logger.warning(f"{self.name}: Map update loop missed its desired rate of "
                                f"{1.0 / self._update_period:.4f}Hz... the loop actually took {took:.4f} seconds")

    def update_map_now(self) -> bool:
        """One update: robot pose, layers, footprint; False when the pose is not available."""
        pose = self.get_robot_pose()
        if pose is None:
            return False
        circles = None if self.obstacle_feed is None else \
            self.obstacle_feed.clearing_circles(self.now_s(), self.global_frame)
        with speaking_for(self), self.lock:
            self._update_static_transforms()
            if circles is not None:
                self.cm.set_clearing_circles(circles)
            self.cm.update_map(pose.x, pose.y, pose.yaw)
            window = self.cm.update_window
            if window is not None:
                self.publisher.touch(*window)
            footprint = self.cm.oriented_footprint(pose.x, pose.y, pose.yaw)
        self.publisher.publish_footprint(footprint)
        self._warn_stale()
        return True

    def _update_static_transforms(self) -> None:
        """A rolling costmap reads a StaticLayer's map through TF (map frame <- global frame)."""
        if not self.cm.rolling_window:
            return
        for layer in self.cm.static_layers():
            if not layer.map_received:
                continue
            try:
                tf = self.tf.lookup_transform(layer.map_frame, self.global_frame, Time())
            except TransformException as err:
                if self.throttle(("static tf", layer.name), 5.0):
                    self.logger.error(f"{self.name}: static layer {layer.name}: {err}")
                continue
            t = tf.transform.translation
            layer.global_to_map = (t.x, t.y, yaw_of(tf.transform.rotation))

    def _warn_stale(self) -> None:
        if self.cm.is_current():
            return
        now = self.now_s()
        for key in self.cm.stale_sources():
            buffer = self.cm.observation_buffer(key)
            if self.throttle(("stale", key), 2.0):
                self.logger.warning(
                    f"{self.name}: The {key} observation buffer ({buffer.source.topic}) has not been updated for "
                    f"{now - buffer.last_updated:.2f} seconds, and it should be updated every "
                    f"{buffer.source.expected_update_rate:.2f} seconds.")

    # -- what planners, move_base and recoveries use --------------------------------------------------
    @property
    def costmap(self) -> Costmap2D:
        """The master grid; hold `lock` while reading it."""
        return self.cm.costmap

    @property
    def footprint(self) -> np.ndarray:
        """Padded footprint in the robot frame."""
        return self.cm.footprint

    def oriented_footprint(self, x: float, y: float, yaw: float) -> np.ndarray:
        return self.cm.oriented_footprint(x, y, yaw)

    @property
    def inscribed_radius(self) -> float:
        return self.cm.inscribed_radius

    @property
    def circumscribed_radius(self) -> float:
        return self.cm.circumscribed_radius

    @property
    def initialized(self) -> bool:
        """True after the first successful update."""
        return self.cm.initialized

    def is_current(self) -> bool:
        return self.cm.is_current()

    def stale_sources(self) -> list[str]:
        return self.cm.stale_sources()

    def reset_layers(self) -> None:
        """clear_costmaps: every layer and the master back to their defaults."""
        with self.lock:
            self.cm.reset_layers()
            self.publisher.touch_all()

    def forget_history(self) -> None:
        """Time jumped back: layers, observations and the message filter queues start again, and the
        next update publishes the whole map."""
        self.input.clear_queues()
        with self.lock:
            self.cm.forget_history()
            self.publisher.touch_all()
        self._last_publish_s = -math.inf

    def clear_layers_outside(self, robot_x: float, robot_y: float, reset_distance: float, layer_names=None,
                             invert_area: bool = False) -> list[str]:
        """clear_costmap_recovery; see CostmapCore.clear_layers_outside."""
        with self.lock:
            return self.cm.clear_layers_outside(robot_x, robot_y, reset_distance, layer_names, invert_area)
