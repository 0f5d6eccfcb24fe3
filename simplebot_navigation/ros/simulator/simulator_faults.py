"""Sensor faults the simulator injects on request, so that what navigation does when a lidar, odometry or TF
fails can be tried on the running stack with standard tools:

    ros2 param set /simulator faults.scan_dropout front_laser_link   # or "all", or "" to end it
    ros2 param set /simulator faults.odometry_dropout true            # no odometry and no odom TF
    ros2 param set /simulator faults.tf_delay 1.0                     # TF arrives 1 s after its stamp
"""

from __future__ import annotations

import copy
import math
from collections import deque

from geometry_msgs.msg import TransformStamped
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

#: longer delays than this are refused: the transform buffers keep 10 s of history
MAX_TF_DELAY_S = 5.0


class SimulatorFaults:
    """The faults currently injected; the simulator asks before it publishes."""

    def __init__(self, node: Node, scan_frames):
        self._node = node
        self._scan_frames = tuple(scan_frames)
        self.dropped_scans: frozenset[str] = frozenset()
        self.odometry_dropout = False
        self.tf_delay = 0.0
        self._delayed: deque[tuple[float, list[TransformStamped]]] = deque()
        describe = {
            "faults.scan_dropout": ("", "laser frames whose scans are not published (comma-separated, 'all', "
                                        "or empty)"),
            "faults.odometry_dropout": (False, "publish neither odometry nor the odom -> base_link transform"),
            "faults.tf_delay": (0.0, f"seconds between a transform's stamp and its publication "
                                     f"(0 to {MAX_TF_DELAY_S:g})"),
        }
        node.add_on_set_parameters_callback(self._on_set)
        for name, (default, text) in describe.items():
            node.declare_parameter(name, default, ParameterDescriptor(description=text, dynamic_typing=True))

    def drops_scan(self, frame: str) -> bool:
        return frame in self.dropped_scans

    def transforms_due(self, now: float, transforms: list[TransformStamped]) -> list[TransformStamped]:
        """The transforms to publish now: these at once without a delay, otherwise the ones whose delay is over."""
        if self.tf_delay <= 0 and not self._delayed:
            return transforms
        if self.tf_delay > 0:
            self._delayed.append((now + self.tf_delay, copy.deepcopy(transforms)))
        due = []
        while self._delayed and (self.tf_delay <= 0 or self._delayed[0][0] <= now + 1e-9):
            due.extend(self._delayed.popleft()[1])
        return due + (transforms if self.tf_delay <= 0 else [])

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        changes = {}
        for param in params:
            if not param.name.startswith("faults."):
                continue
            reason = self._check(param, changes)
            if reason:
                return SetParametersResult(successful=False, reason=f"{param.name}: {reason}")
        before = self.describe()
        for name, value in changes.items():
            setattr(self, name, value)
        if self.describe() != before:
            self._node.get_logger().warn(f"injected faults now: {self.describe()}")
        return SetParametersResult(successful=True)

    def _check(self, param: Parameter, changes: dict) -> str:
        value = param.value
        if param.name == "faults.scan_dropout":
            if not isinstance(value, str):
                return f"expected a string of laser frames, got {value!r}"
            frames = {f.strip() for f in value.split(",") if f.strip()}
            if frames == {"all"}:
                frames = set(self._scan_frames)
            unknown = frames - set(self._scan_frames)
            if unknown:
                return f"unknown laser frame(s) {sorted(unknown)}; known: {', '.join(self._scan_frames)}, all"
            changes["dropped_scans"] = frozenset(frames)
        elif param.name == "faults.odometry_dropout":
            if not isinstance(value, bool):
                return f"expected true or false, got {value!r}"
            changes["odometry_dropout"] = value
        elif param.name == "faults.tf_delay":
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not (math.isfinite(value) and 0 <= value <= MAX_TF_DELAY_S):
                return f"expected seconds in [0, {MAX_TF_DELAY_S:g}], got {value!r}"
            changes["tf_delay"] = float(value)
        else:
            return "no such fault (faults.scan_dropout, faults.odometry_dropout, faults.tf_delay)"
        return ""

    def describe(self) -> str:
        parts = []
        if self.dropped_scans:
            parts.append(f"no scans from {', '.join(sorted(self.dropped_scans))}")
        if self.odometry_dropout:
            parts.append("no odometry")
        if self.tf_delay > 0:
            parts.append(f"TF delayed by {self.tf_delay:g} s")
        return "; ".join(parts) or "none"
