"""One simplebot inside a SimplebotSim world: its body, wheels, odometry, lidars and contacts.

The world (floor, obstacles, the ray mesh, stepping) belongs to SimplebotSim; a robot only drives its
wheels before a physics step and reads them, its contacts and its scans after it.

Other robots' lidars see a robot as its *hull*: a prism of the footprint from the floor to just above
the lidar plane, moved to the robot's pose before every cast and visible to rays only. The URDF's
deck lies below the lidar plane (as on the lab's robot), so without the hull another robot would
show up only as its two laser housings.
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from simplebot_description import RobotDescription

from simplebot_navigation.sim.diff_drive import DiffDriveParams, OdomNoise, WheelOdometry, ramp, wheel_targets
from simplebot_navigation.sim.lidar import LaserScanData, LidarRig
from simplebot_navigation.sim.world import Pose2D

# How far the hull reaches above the highest lidar plane, so that every other lidar's beams meet it.
_HULL_ABOVE_LIDARS = 0.05
# Contacts Bullet keeps with a positive gap (up to its breaking threshold) are near misses.
_CONTACT_DISTANCE = 1e-4
# A collision is the robot's own ("moving") if a wheel was driven faster than this (m/s at the rim, by the
# command or by the ramp still slowing it down) within the last DRIVING_WINDOW_S; else the robot was struck
# while standing.
DRIVING_SPEED = 0.05
DRIVING_WINDOW_S = 0.5


@dataclass(frozen=True)
class Odometry:
    """nav_msgs/Odometry content: pose of child_frame in frame, twist in child_frame."""

    stamp: float
    frame_id: str
    child_frame_id: str
    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    wz: float


@dataclass(frozen=True)
class CollisionReport:
    """Contacts of the robot with anything but the floor (obstacles, moving obstacles and other robots).

    ``count`` counts collisions (a contact with a body that was not touched the step before), the sum
    of ``count_moving`` (the robot drove itself, see DRIVING_SPEED) and ``count_standing`` (it stood and
    was struck); ``last_*`` describe the most recent step with a contact, ``last_kind`` the most recent
    collision ("moving" or "standing").
    """

    count: int
    in_contact: bool
    last_point: tuple[float, float, float] | None
    last_obstacle: str | None
    last_stamp: float | None
    count_moving: int = 0
    count_standing: int = 0
    last_kind: str | None = None


@dataclass(frozen=True)
class JointStates:
    names: tuple[str, ...]
    positions: tuple[float, ...]
    velocities: tuple[float, ...]


@dataclass(frozen=True)
class CollisionGroups:
    """Bullet filter group and mask of the robot's links, and the group of its hull."""

    links: int
    links_mask: int
    hull: int


class SimRobot:
    """A simplebot body in a pybullet client; SimplebotSim creates one per start pose."""

    def __init__(self, client: int, description: RobotDescription, start: Pose2D, groups: CollisionGroups, *,
                 drive: DiffDriveParams, range_noise_std: float, odom_noise: OdomNoise | None,
                 seed: np.random.SeedSequence):
        self.description = description
        self.start = start
        self.drive = drive
        # The yaw acceleration limit as a bound on the wheels' speed difference, per second.
        self._turn_accel = None if drive.max_yaw_accel is None \
            else drive.max_yaw_accel * description.wheel_separation / description.wheel_radius
        self.hull_group = groups.hull
        self._client = client
        odom_rng, lidar_rng = (np.random.default_rng(s) for s in seed.spawn(2))
        self._odom = WheelOdometry(description.wheel_separation, description.wheel_radius, odom_noise, odom_rng)
        self.lidars = LidarRig(description, range_noise_std, lidar_rng)
        # (v, w, received at): one tuple, so a command set from another thread is never half-new.
        self._cmd: tuple[float, float, float] | None = None
        self._wheel_cmd = np.zeros(2)
        self._stopped = np.zeros(2)
        self._target_of: tuple | None = None  # (command, its wheel targets): computed once per command
        self._pending_scans: list[LaserScanData] = []
        self._counts = {"moving": 0, "standing": 0}
        self._last_kind: str | None = None
        self._driven_at = -math.inf     # sim time the wheels were last driven faster than DRIVING_SPEED
        self._touching: set[int] = set()
        self._last_contact: tuple | None = None
        self._load(groups)
        self._hull = self._create_hull(groups.hull)

    def _load(self, groups: CollisionGroups) -> None:
        c, start = self._client, self.start
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write(self.description.urdf)
        try:
            # Implicit cylinders: the round chassis collides as a true circle, not a polygon.
            body = pb.loadURDF(f.name, [start.x, start.y, 0.0], pb.getQuaternionFromEuler([0, 0, start.yaw]),
                               flags=pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_USE_IMPLICIT_CYLINDER,
                               physicsClientId=c)
        finally:
            os.unlink(f.name)
        joints = {pb.getJointInfo(body, i, physicsClientId=c)[1].decode(): i
                  for i in range(pb.getNumJoints(body, physicsClientId=c))}
        self._wheel_names = ("left_wheel_joint", "right_wheel_joint")
        self._wheels = [joints[name] for name in self._wheel_names]
        for link in (-1, *joints.values()):
            # Only the driven wheels grip; casters and chassis slide (casters are ideal ball casters).
            friction = 1.0 if link in self._wheels else 0.0
            pb.changeDynamics(body, link, lateralFriction=friction, rollingFriction=0.0,
                              spinningFriction=0.0, physicsClientId=c)
            pb.setCollisionFilterGroupMask(body, link, groups.links, groups.links_mask, physicsClientId=c)
        # pybullet reports the base's centre of mass; base_link is offset from it by the inertial origin.
        info = pb.getDynamicsInfo(body, -1, physicsClientId=c)
        self._com_to_link = pb.invertTransform(info[3], info[4])
        self.body = body
        self._apply_wheel_cmd()

    def _create_hull(self, group: int) -> int:
        c, d = self._client, self.description
        height = max(z for _, _, z, _ in d.laser_poses.values()) + _HULL_ABOVE_LIDARS
        if d.radius is not None:
            shape = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=d.radius, height=height, physicsClientId=c)
        else:  # the footprint prism; without indices pybullet takes the vertices' convex hull
            vertices = [[x, y, z] for x, y in d.footprint for z in (-height / 2, height / 2)]
            shape = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, physicsClientId=c)
        hull = pb.createMultiBody(0, shape, physicsClientId=c)
        self._hull_z = height / 2
        # Rays carry group 1 (see simulator.py); nothing else collides with the hull.
        pb.setCollisionFilterGroupMask(hull, -1, group, 1, physicsClientId=c)
        return hull

    # -- driving and stepping -------------------------------------------------------------------

    def set_cmd_vel(self, v: float, w: float, now: float) -> None:
        if not (math.isfinite(v) and math.isfinite(w)):
            raise ValueError(f"cmd_vel with non-finite values ignored: linear.x={v}, angular.z={w}")
        self._cmd = (float(v), float(w), float(now))

    def before_step(self, now: float, dt: float) -> None:
        """Ramp the wheel speeds towards the current command."""
        target = self._wheel_target(now)
        if target is not self._wheel_cmd:
            wheel_cmd = ramp(self._wheel_cmd, target, self.drive.max_wheel_accel * dt,
                             None if self._turn_accel is None else self._turn_accel * dt)
            changed = not np.array_equal(wheel_cmd, self._wheel_cmd)
            # Once the ramp reaches the target, the target itself is kept: the identity test above
            # then skips the ramp while the wheels hold their speed.
            self._wheel_cmd = target if np.array_equal(wheel_cmd, target) else wheel_cmd
            if changed:
                self._apply_wheel_cmd()
        rim = self.description.wheel_radius * max(abs(target[0]), abs(target[1]),
                                                  abs(self._wheel_cmd[0]), abs(self._wheel_cmd[1]))
        if rim > DRIVING_SPEED:
            self._driven_at = now

    def after_step(self, now: float, dt: float, labels: dict[int, str], floor: int) -> None:
        """Odometry from the wheels and the contacts of this step."""
        states = pb.getJointStates(self.body, self._wheels, physicsClientId=self._client)
        self._odom.update((states[0][1], states[1][1]), dt)
        touching = {}
        for contact in pb.getContactPoints(bodyA=self.body, physicsClientId=self._client):
            body, distance = contact[2], contact[8]
            if body == floor or distance > _CONTACT_DISTANCE:
                continue
            if body not in touching or distance < touching[body][8]:
                touching[body] = contact
        new = len(touching.keys() - self._touching)
        if new:
            self._last_kind = "moving" if now - self._driven_at <= DRIVING_WINDOW_S + 1e-9 else "standing"
            self._counts[self._last_kind] += new
        self._touching = set(touching)
        if touching:
            deepest = min(touching.values(), key=lambda contact: contact[8])
            self._last_contact = (tuple(deepest[6]), labels.get(deepest[2], str(deepest[2])), now)

    def _wheel_target(self, now: float) -> np.ndarray:
        """Wheel speeds the current command asks for (zero without one, or after its timeout)."""
        cmd = self._cmd
        if cmd is None or now - cmd[2] > self.drive.cmd_timeout:
            return self._stopped
        if self._target_of is None or self._target_of[0] is not cmd:
            self._target_of = (cmd, wheel_targets(cmd[0], cmd[1], self.description.wheel_separation,
                                                  self.description.wheel_radius, self.drive.max_wheel_speed,
                                                  self.drive.max_yaw_rate))
        return self._target_of[1]

    def _apply_wheel_cmd(self) -> None:
        torque = self.drive.max_wheel_torque
        pb.setJointMotorControlArray(self.body, self._wheels, pb.VELOCITY_CONTROL,
                                     targetVelocities=self._wheel_cmd.tolist(), forces=[torque, torque],
                                     physicsClientId=self._client)

    # -- lidars ---------------------------------------------------------------------------------

    def base_link_pose(self) -> tuple[np.ndarray, np.ndarray]:
        com_pos, com_orn = pb.getBasePositionAndOrientation(self.body, physicsClientId=self._client)
        pos, orn = pb.multiplyTransforms(com_pos, com_orn, *self._com_to_link)
        rotation = np.array(pb.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return np.array(pos), rotation

    def move_hull(self) -> None:
        """Put the hull where the robot is now, upright, before the lidars cast."""
        c = self._client
        com, com_orn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        (x, y, _), orn = pb.multiplyTransforms(com, com_orn, *self._com_to_link)
        yaw = pb.getEulerFromQuaternion(orn)[2]
        pb.resetBasePositionAndOrientation(self._hull, [x, y, self._hull_z], pb.getQuaternionFromEuler([0, 0, yaw]),
                                           physicsClientId=c)

    def kidnap(self, pose: Pose2D) -> None:
        """Put the robot at ``pose`` (world frame), standing, its command dropped: its odometry does not notice,
        as a robot carried away does not (the kidnapped-robot test of a localizer)."""
        c = self._client
        _, com_orn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        link_to_com = pb.invertTransform(*self._com_to_link)
        base_z = self.base_link_pose()[0][2]
        com, orn = pb.multiplyTransforms([pose.x, pose.y, base_z], pb.getQuaternionFromEuler([0, 0, pose.yaw]),
                                         *link_to_com)
        pb.resetBasePositionAndOrientation(self.body, com, orn, physicsClientId=c)
        pb.resetBaseVelocity(self.body, [0, 0, 0], [0, 0, 0], physicsClientId=c)
        for wheel in self._wheels:
            angle = pb.getJointState(self.body, wheel, physicsClientId=c)[0]
            pb.resetJointState(self.body, wheel, angle, 0.0, physicsClientId=c)
        self._cmd, self._wheel_cmd = None, self._stopped
        self._apply_wheel_cmd()
        self.move_hull()

    def add_scans(self, scans: list[LaserScanData]) -> None:
        self._pending_scans += scans

    # -- outputs --------------------------------------------------------------------------------

    def odometry(self, now: float) -> Odometry:
        """Wheel odometry: base_link in the odom frame (the start pose), twist in base_link."""
        o = self._odom
        return Odometry(now, "odom", self.description.base_frame, o.x, o.y, o.yaw, o.v, 0.0, o.w)

    def ground_truth(self, now: float) -> Odometry:
        """True base_link pose in the world frame and its twist in base_link."""
        # Plain floats: numpy's overhead on 3-vectors made this the costliest call a node makes at 50 Hz.
        c = self._client
        com, com_orn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        (x, y, z), orn = pb.multiplyTransforms(com, com_orn, *self._com_to_link)
        m = pb.getMatrixFromQuaternion(orn)  # row-major rotation base_link -> world
        (lx, ly, lz), (ax, ay, az) = pb.getBaseVelocity(self.body, physicsClientId=c)
        rx, ry, rz = x - com[0], y - com[1], z - com[2]
        # Velocity of base_link's origin: the centre of mass's plus omega x r, then into base_link.
        vx, vy, vz = lx + ay * rz - az * ry, ly + az * rx - ax * rz, lz + ax * ry - ay * rx
        return Odometry(now, "world", self.description.base_frame, x, y, math.atan2(m[3], m[0]),
                        m[0] * vx + m[3] * vy + m[6] * vz, m[1] * vx + m[4] * vy + m[7] * vz, az)

    def due_scans(self) -> list[LaserScanData]:
        """Scans taken since the last call, oldest first."""
        scans, self._pending_scans = self._pending_scans, []
        return scans

    def collisions(self) -> CollisionReport:
        point, label, stamp = self._last_contact or (None, None, None)
        moving, standing = self._counts["moving"], self._counts["standing"]
        return CollisionReport(moving + standing, bool(self._touching), point, label, stamp, moving, standing,
                               self._last_kind)

    def joint_states(self) -> JointStates:
        """Wheel angles and speeds (for /joint_states and the wheels' transforms)."""
        states = pb.getJointStates(self.body, self._wheels, physicsClientId=self._client)
        return JointStates(self._wheel_names, tuple(s[0] for s in states), tuple(s[1] for s in states))
