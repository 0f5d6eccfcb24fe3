"""The simplebot URDF and the facts other parts derive from it.

The xacro file is the single source of truth: footprint, laser mounts, scan settings and wheel
geometry are read back from the processed URDF (with yourdfpy, plus the Gazebo sensor blocks, which
URDF parsers ignore), so a change to the xacro cannot drift apart from what the costmaps, planners
and the simulator assume.
"""

from __future__ import annotations

import functools
import io
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np
import xacro
import yourdfpy

XACRO_PATH = Path(__file__).resolve().parent / "urdf" / "simplebot.urdf.xacro"
BODIES = ("box", "round")
RADIUS_RANGE = (0.15, 1.0)
BASE_FRAME = "base_link"
WHEEL_JOINTS = ("left_wheel_joint", "right_wheel_joint")


@dataclass(frozen=True)
class ScanParams:
    """One ray sensor as the Gazebo block declares it (the LaserScan header fields)."""

    frame: str
    topic: str
    samples: int
    angle_min: float
    angle_max: float
    range_min: float
    range_max: float
    update_rate: float

    @property
    def angle_increment(self) -> float:
        return (self.angle_max - self.angle_min) / (self.samples - 1)


@dataclass(frozen=True)
class FixedJoint:
    """A fixed URDF joint, i.e. one /tf_static transform parent -> child."""

    name: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]


@dataclass(frozen=True)
class RobotDescription:
    """The processed URDF and what navigation needs to know about the robot.

    Poses are in base_link, which lies on the floor midway between the driven wheels.
    ``footprint`` is the chassis polygon (box body) and ``radius`` the chassis radius (round body);
    the other one is None, matching the costmap's choice between ``footprint`` and ``robot_radius``.
    ``mass`` is the whole robot's (kg, every link's): what the drive's wheel torque has to accelerate.
    """

    urdf: str
    body: str
    footprint: tuple[tuple[float, float], ...] | None
    radius: float | None
    laser_poses: Mapping[str, tuple[float, float, float, float]]  # frame -> (x, y, z, yaw)
    scans: Mapping[str, ScanParams]  # frame -> sensor
    wheel_separation: float
    wheel_radius: float
    fixed_joints: tuple[FixedJoint, ...]
    mass: float
    base_frame: str = BASE_FRAME

    @property
    def width(self) -> float:
        """Extent across the direction of travel: what has to fit through a door."""
        if self.radius is not None:
            return 2.0 * self.radius
        ys = [y for _, y in self.footprint]
        return max(ys) - min(ys)

    @property
    def circumscribed_radius(self) -> float:
        if self.radius is not None:
            return self.radius
        return max(math.hypot(x, y) for x, y in self.footprint)

    @property
    def inscribed_radius(self) -> float:
        """Distance from base_link to the nearest footprint edge (the polygon is convex)."""
        if self.radius is not None:
            return self.radius
        pts = self.footprint
        dists = []
        for (x1, y1), (x2, y2) in zip(pts, pts[1:] + pts[:1]):
            dists.append(abs(x1 * y2 - x2 * y1) / math.hypot(x2 - x1, y2 - y1))
        return min(dists)


def robot_description(body: str = "box", radius: float = 0.3) -> RobotDescription:
    """Run xacro on simplebot.urdf.xacro with the given args and derive the robot's facts.

    ``radius`` only matters for the round body. Raises ValueError for an unknown body or a radius
    outside RADIUS_RANGE.
    """
    if body not in BODIES:
        raise ValueError(f"robot body must be one of {', '.join(BODIES)}; got {body!r}")
    if isinstance(radius, bool) or not isinstance(radius, (int, float)) or not math.isfinite(radius):
        raise ValueError(f"robot radius must be a finite number; got {radius!r}")
    if body == "round" and not RADIUS_RANGE[0] <= radius <= RADIUS_RANGE[1]:
        raise ValueError(
            f"robot radius must be within {RADIUS_RANGE[0]} .. {RADIUS_RANGE[1]} m; got {radius}"
        )
    # The box ignores the radius; normalising it keeps the cache to one entry per box.
    return _described(body, float(radius) if body == "round" else 0.3)


@functools.lru_cache(maxsize=16)
def _described(body: str, radius: float) -> RobotDescription:
    urdf = urdf_string(body, radius)
    robot = yourdfpy.URDF.load(io.StringIO(urdf), build_scene_graph=False, load_meshes=False)
    footprint, chassis_radius = _chassis(robot, body)
    wheel_separation, wheel_radius = _wheels(robot)
    fixed = tuple(_fixed_joint(j) for j in robot.robot.joints if j.type == "fixed")
    scans = _scans(urdf)
    laser_poses = {}
    for frame in scans:
        joint = next((j for j in fixed if j.child == frame), None)
        if joint is None or joint.parent != BASE_FRAME:
            raise ValueError(f"{XACRO_PATH.name}: sensor frame {frame} is not fixed to {BASE_FRAME}")
        laser_poses[frame] = (*joint.xyz, joint.rpy[2])
    return RobotDescription(
        urdf=urdf,
        body=body,
        footprint=footprint,
        radius=chassis_radius,
        laser_poses=MappingProxyType(laser_poses),
        scans=MappingProxyType(scans),
        wheel_separation=wheel_separation,
        wheel_radius=wheel_radius,
        fixed_joints=fixed,
        mass=sum(link.inertial.mass for link in robot.robot.links if link.inertial is not None),
    )


def urdf_string(body: str, radius: float) -> str:
    """The processed URDF XML (what /robot_description carries)."""
    try:
        doc = xacro.process_file(str(XACRO_PATH), mappings={"body": body, "radius": repr(radius)})
    except xacro.XacroException as exc:
        raise ValueError(f"{XACRO_PATH.name}: {exc}") from exc
    return doc.toprettyxml(indent="  ")


def _chassis(robot: yourdfpy.URDF, body: str):
    collisions = robot.link_map[BASE_FRAME].collisions
    if len(collisions) != 1:
        raise ValueError(f"{XACRO_PATH.name}: {BASE_FRAME} must have exactly one collision (the chassis)")
    geometry = collisions[0].geometry
    origin = collisions[0].origin if collisions[0].origin is not None else np.eye(4)
    cx, cy = float(origin[0, 3]), float(origin[1, 3])
    if body == "box":
        sx, sy = (float(v) for v in geometry.box.size[:2])
        # Same corner order as the lab's costmap_common.yaml footprint.
        footprint = tuple(
            (round(cx + dx * sx / 2, 9), round(cy + dy * sy / 2, 9))
            for dx, dy in ((1, 1), (1, -1), (-1, -1), (-1, 1))
        )
        return footprint, None
    return None, float(geometry.cylinder.radius)


def _wheels(robot: yourdfpy.URDF) -> tuple[float, float]:
    joints = [robot.joint_map[name] for name in WHEEL_JOINTS]
    left, right = (float(j.origin[1, 3]) for j in joints)
    radii = set()
    for j in joints:
        geometry = robot.link_map[j.child].collisions[0].geometry
        radii.add(float((geometry.sphere or geometry.cylinder).radius))
    if len(radii) != 1:
        raise ValueError(f"{XACRO_PATH.name}: the driven wheels have different radii {sorted(radii)}")
    return round(left - right, 12), radii.pop()


def _fixed_joint(joint) -> FixedJoint:
    m = joint.origin if joint.origin is not None else np.eye(4)
    # Fixed joints here only rotate about z (lasers) or not at all; rpy from the matrix for generality.
    roll = math.atan2(m[2, 1], m[2, 2])
    pitch = math.atan2(-m[2, 0], math.hypot(m[2, 1], m[2, 2]))
    yaw = math.atan2(m[1, 0], m[0, 0])
    xyz = tuple(round(float(v), 12) + 0.0 for v in m[:3, 3])
    rpy = tuple(round(float(v), 12) + 0.0 for v in (roll, pitch, yaw))
    return FixedJoint(joint.name, joint.parent, joint.child, xyz, rpy)


def _scans(urdf: str) -> dict[str, ScanParams]:
    root = ET.fromstring(urdf)
    scans = {}
    for gazebo in root.findall("gazebo"):
        sensor = gazebo.find("sensor[@type='ray']")
        if sensor is None:
            continue

        def text(path, _sensor=sensor):
            node = _sensor.find(path)
            if node is None or node.text is None:
                raise ValueError(f"{XACRO_PATH.name}: sensor {_sensor.get('name')} lacks <{path}>")
            return node.text.strip()

        frame = text("plugin/frameName")
        scans[frame] = ScanParams(
            frame=frame,
            topic=text("plugin/topicName"),
            samples=int(text("ray/scan/horizontal/samples")),
            angle_min=float(text("ray/scan/horizontal/min_angle")),
            angle_max=float(text("ray/scan/horizontal/max_angle")),
            range_min=float(text("ray/range/min")),
            range_max=float(text("ray/range/max")),
            update_rate=float(text("update_rate")),
        )
    return scans
