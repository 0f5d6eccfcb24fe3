"""The pybullet simplebot: physics, diff drive, wheel odometry, lidars and contacts, without ROS.

One instance owns one pybullet DIRECT client, so several simulators can live in one process. Time
advances only through step()/step_until(); with the same world, commands and seed every run is
identical.

Physics runs at 100 Hz by default: the robot is slow (about 1 m/s, so 1 cm per step, no tunnelling
through 0.1 m walls) and rests on rigid wheels and casters, which Bullet's solver keeps stable at
10 ms steps (odometry and ground truth agree to a millimetre over metres of driving); 100 Hz divides
the 10 Hz lidars and the usual 20/50 Hz controller and odometry rates, and is cheaper than Bullet's
customary 240 Hz, though not 2.4x: the lidar rays dominate the cost (bench/sim_speed.py).

Obstacles exist twice: as primitives (boxes, cylinders) for contacts, and merged into one static
triangle mesh that only the lidar rays see (collision filter groups keep the two apart). Ray casts
against a BVH mesh cost half of those against convex primitives, and the robot itself is not in the
ray group, so a scan can never see its own body.
"""

from __future__ import annotations

import math
import os
import tempfile
import weakref
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from simplebot_description import RobotDescription

from .diff_drive import DiffDriveParams, OdomNoise, WheelOdometry, ramp, wheel_targets
from .lidar import LaserScanData, LidarRig
from .world import Box, Cylinder, World

# Collision filter groups. Bullet lets a ray hit an object only if the object's mask has bit 1
# (the ray's own group), so only the ray mesh carries that bit.
_RAY = 1
_ROBOT = 2
_FLOOR = 4
_OBSTACLE = 8
_RAY_MESH = 16
_CYLINDER_SIDES = 64
# Contacts Bullet keeps with a positive gap (up to its breaking threshold) are near misses.
_CONTACT_DISTANCE = 1e-4


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
    """Contacts of the robot with anything but the floor.

    ``count`` counts collisions (a contact with an obstacle that was not touched the step before);
    ``last_*`` describe the most recent step with a contact.
    """

    count: int
    in_contact: bool
    last_point: tuple[float, float, float] | None
    last_obstacle: str | None
    last_stamp: float | None


@dataclass(frozen=True)
class JointStates:
    names: tuple[str, ...]
    positions: tuple[float, ...]
    velocities: tuple[float, ...]


class SimplebotSim:
    """One simulated simplebot in one world.

    The ROS node calls set_cmd_vel() when a Twist arrives, step_until() to advance the clock, and
    publishes odometry(), ground_truth(), due_scans() and collisions().

    physics_rate must be a multiple of the lidar rate (10 Hz). ``seed`` feeds the lidar range noise
    (``range_noise_std``, metres, off by default) and the odometry errors (``odom_noise``, off by
    default). ``ray_threads`` is passed to rayTestBatch (1: the other core stays free for the nodes).
    """

    def __init__(self, world: World, description: RobotDescription, *, physics_rate: float = 100.0,
                 seed: int = 0, drive: DiffDriveParams = DiffDriveParams(),
                 range_noise_std: float = 0.0, odom_noise: OdomNoise | None = None,
                 ray_threads: int = 1):
        if isinstance(physics_rate, bool) or not isinstance(physics_rate, (int, float)) \
                or not math.isfinite(physics_rate) or physics_rate <= 0:
            raise ValueError(f"physics_rate must be a positive number of Hz, got {physics_rate!r}")
        if isinstance(seed, bool) or not isinstance(seed, int):
            raise ValueError(f"seed must be an int, got {seed!r}")
        self.world = world
        self.description = description
        self.physics_rate = float(physics_rate)
        self.dt = 1.0 / self.physics_rate
        self.drive = drive
        self._ray_threads = ray_threads
        odom_rng, lidar_rng = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2))
        self._odom = WheelOdometry(description.wheel_separation, description.wheel_radius, odom_noise, odom_rng)
        self._lidars = LidarRig(description, range_noise_std, lidar_rng)
        self._scan_period_steps = []
        for sensor in self._lidars.sensors:
            ratio = self.physics_rate / sensor.update_rate
            if abs(ratio - round(ratio)) > 1e-9:
                raise ValueError(f"physics_rate {physics_rate} Hz must be a multiple of the {sensor.frame} "
                                 f"update rate {sensor.update_rate} Hz")
            self._scan_period_steps.append(round(ratio))

        self._client = pb.connect(pb.DIRECT)
        self._finalizer = weakref.finalize(self, _disconnect, self._client)
        self._steps = 0
        # (v, w, received at): one tuple, so a command set from another thread is never half-new.
        self._cmd: tuple[float, float, float] | None = None
        self._wheel_cmd = np.zeros(2)
        self._stopped = np.zeros(2)
        self._target_of: tuple | None = None  # (command, its wheel targets): computed once per command
        self._pending_scans: list[LaserScanData] = []
        self._collision_count = 0
        self._touching: set[int] = set()
        self._last_contact: tuple | None = None
        self._build()

    # -- construction -------------------------------------------------------------------------

    def _build(self) -> None:
        c = self._client
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0, deterministicOverlappingPairs=1,
                                     physicsClientId=c)
        self._floor = pb.createMultiBody(0, pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c),
                                         physicsClientId=c)
        pb.changeDynamics(self._floor, -1, lateralFriction=1.0, physicsClientId=c)
        pb.setCollisionFilterGroupMask(self._floor, -1, _FLOOR, _ROBOT, physicsClientId=c)

        self._obstacle_labels: dict[int, str] = {}
        for label, shape in self.world.obstacles():
            body = self._create_obstacle(shape)
            pb.setCollisionFilterGroupMask(body, -1, _OBSTACLE, _ROBOT, physicsClientId=c)
            self._obstacle_labels[body] = f"{label} ({shape.name})" if shape.name else label
        vertices, indices = _obstacle_mesh(self.world)
        if indices:
            mesh = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, indices=indices, physicsClientId=c)
            self._ray_mesh = pb.createMultiBody(0, mesh, physicsClientId=c)
            pb.setCollisionFilterGroupMask(self._ray_mesh, -1, _RAY_MESH, _RAY, physicsClientId=c)

        start = self.world.start
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write(self.description.urdf)
        try:
            # Implicit cylinders: the round chassis collides as a true circle, not a polygon.
            self._robot = pb.loadURDF(f.name, [start.x, start.y, 0.0], pb.getQuaternionFromEuler([0, 0, start.yaw]),
                                      flags=pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_USE_IMPLICIT_CYLINDER,
                                      physicsClientId=c)
        finally:
            os.unlink(f.name)
        joints = {pb.getJointInfo(self._robot, i, physicsClientId=c)[1].decode(): i
                  for i in range(pb.getNumJoints(self._robot, physicsClientId=c))}
        self._wheel_names = ("left_wheel_joint", "right_wheel_joint")
        self._wheels = [joints[name] for name in self._wheel_names]
        for link in (-1, *joints.values()):
            # Only the driven wheels grip; casters and chassis slide (casters are ideal ball casters).
            friction = 1.0 if link in self._wheels else 0.0
            pb.changeDynamics(self._robot, link, lateralFriction=friction, rollingFriction=0.0,
                              spinningFriction=0.0, physicsClientId=c)
            pb.setCollisionFilterGroupMask(self._robot, link, _ROBOT, _FLOOR | _OBSTACLE, physicsClientId=c)
        self._apply_wheel_cmd()
        # pybullet reports the base's centre of mass; base_link is offset from it by the inertial origin.
        info = pb.getDynamicsInfo(self._robot, -1, physicsClientId=c)
        self._com_to_link = pb.invertTransform(info[3], info[4])

    def _create_obstacle(self, shape: Box | Cylinder) -> int:
        c = self._client
        if isinstance(shape, Box):
            col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[shape.size[0] / 2, shape.size[1] / 2,
                                                                    shape.height / 2], physicsClientId=c)
            orientation = pb.getQuaternionFromEuler([0, 0, shape.yaw])
        else:
            col = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=shape.radius, height=shape.height,
                                          physicsClientId=c)
            orientation = [0, 0, 0, 1]
        return pb.createMultiBody(0, col, basePosition=[*shape.center, shape.height / 2],
                                  baseOrientation=orientation, physicsClientId=c)

    # -- commands and stepping ----------------------------------------------------------------

    @property
    def sim_time(self) -> float:
        return self._steps / self.physics_rate

    def set_cmd_vel(self, v: float, w: float, now: float | None = None) -> None:
        """Command body velocity (m/s, rad/s), received at sim time ``now`` (default: current).

        Raises ValueError for NaN/inf; the previous command then stays in force (and times out).
        """
        if not (math.isfinite(v) and math.isfinite(w)):
            raise ValueError(f"cmd_vel with non-finite values ignored: linear.x={v}, angular.z={w}")
        self._cmd = (float(v), float(w), self.sim_time if now is None else float(now))

    def step(self) -> None:
        """Advance one physics step: drive control, physics, odometry, contacts, due scans."""
        c = self._client
        target = self._wheel_target()
        if target is not self._wheel_cmd:
            wheel_cmd = ramp(self._wheel_cmd, target, self.drive.max_wheel_accel * self.dt)
            changed = not np.array_equal(wheel_cmd, self._wheel_cmd)
            # Once the ramp reaches the target, the target itself is kept: the identity test above
            # then skips the ramp while the wheels hold their speed.
            self._wheel_cmd = target if np.array_equal(wheel_cmd, target) else wheel_cmd
            if changed:
                self._apply_wheel_cmd()
        pb.stepSimulation(physicsClientId=c)
        self._steps += 1
        states = pb.getJointStates(self._robot, self._wheels, physicsClientId=c)
        self._odom.update((states[0][1], states[1][1]), self.dt)
        self._check_contacts()
        due = [i for i, period in enumerate(self._scan_period_steps) if self._steps % period == 0]
        if due:
            self._cast(due)

    def _wheel_target(self) -> np.ndarray:
        """Wheel speeds the current command asks for (zero without one, or after its timeout)."""
        cmd = self._cmd
        if cmd is None or self.sim_time - cmd[2] > self.drive.cmd_timeout:
            return self._stopped
        if self._target_of is None or self._target_of[0] is not cmd:
            self._target_of = (cmd, wheel_targets(cmd[0], cmd[1], self.description.wheel_separation,
                                                  self.description.wheel_radius, self.drive.max_wheel_speed))
        return self._target_of[1]

    def step_until(self, t: float) -> None:
        """Step while the next step ends at or before sim time t."""
        while (self._steps + 1) / self.physics_rate <= t + 1e-9:
            self.step()

    def _apply_wheel_cmd(self) -> None:
        torque = self.drive.max_wheel_torque
        pb.setJointMotorControlArray(self._robot, self._wheels, pb.VELOCITY_CONTROL,
                                     targetVelocities=self._wheel_cmd.tolist(), forces=[torque, torque],
                                     physicsClientId=self._client)

    def _check_contacts(self) -> None:
        touching = {}
        for contact in pb.getContactPoints(bodyA=self._robot, physicsClientId=self._client):
            body, distance = contact[2], contact[8]
            if body == self._floor or distance > _CONTACT_DISTANCE:
                continue
            if body not in touching or distance < touching[body][8]:
                touching[body] = contact
        self._collision_count += len(touching.keys() - self._touching)
        self._touching = set(touching)
        if touching:
            deepest = min(touching.values(), key=lambda contact: contact[8])
            self._last_contact = (tuple(deepest[6]), self._obstacle_labels.get(deepest[2], str(deepest[2])),
                                  self.sim_time)

    def _cast(self, sensors: list[int]) -> None:
        position, rotation = self._base_link_pose()
        origins, ends = self._lidars.rays(sensors, position, rotation)
        results = pb.rayTestBatch(origins, ends, numThreads=self._ray_threads, collisionFilterMask=_RAY_MESH,
                                  physicsClientId=self._client)
        ids, _, fractions, _, _ = zip(*results)
        hit = np.asarray(ids) >= 0
        self._pending_scans += self._lidars.scans(sensors, np.asarray(fractions), hit, self.sim_time)

    def _base_link_pose(self) -> tuple[np.ndarray, np.ndarray]:
        com_pos, com_orn = pb.getBasePositionAndOrientation(self._robot, physicsClientId=self._client)
        pos, orn = pb.multiplyTransforms(com_pos, com_orn, *self._com_to_link)
        rotation = np.array(pb.getMatrixFromQuaternion(orn)).reshape(3, 3)
        return np.array(pos), rotation

    # -- outputs ------------------------------------------------------------------------------

    def odometry(self) -> Odometry:
        """Wheel odometry: base_link in the odom frame (the start pose), twist in base_link."""
        o = self._odom
        return Odometry(self.sim_time, "odom", self.description.base_frame, o.x, o.y, o.yaw, o.v, 0.0, o.w)

    def ground_truth(self) -> Odometry:
        """True base_link pose in the world frame and its twist in base_link."""
        # Plain floats: numpy's overhead on 3-vectors made this the costliest call a node makes at 50 Hz.
        c = self._client
        com, com_orn = pb.getBasePositionAndOrientation(self._robot, physicsClientId=c)
        (x, y, z), orn = pb.multiplyTransforms(com, com_orn, *self._com_to_link)
        m = pb.getMatrixFromQuaternion(orn)  # row-major rotation base_link -> world
        (lx, ly, lz), (ax, ay, az) = pb.getBaseVelocity(self._robot, physicsClientId=c)
        rx, ry, rz = x - com[0], y - com[1], z - com[2]
        # Velocity of base_link's origin: the centre of mass's plus omega x r, then into base_link.
        vx, vy, vz = lx + ay * rz - az * ry, ly + az * rx - ax * rz, lz + ax * ry - ay * rx
        return Odometry(self.sim_time, "world", self.description.base_frame, x, y, math.atan2(m[3], m[0]),
                        m[0] * vx + m[3] * vy + m[6] * vz, m[1] * vx + m[4] * vy + m[7] * vz, az)

    def due_scans(self) -> list[LaserScanData]:
        """Scans taken since the last call, oldest first."""
        scans, self._pending_scans = self._pending_scans, []
        return scans

    def collisions(self) -> CollisionReport:
        point, label, stamp = self._last_contact or (None, None, None)
        return CollisionReport(self._collision_count, bool(self._touching), point, label, stamp)

    def joint_states(self) -> JointStates:
        """Wheel angles and speeds (for /joint_states and the wheels' transforms)."""
        states = pb.getJointStates(self._robot, self._wheels, physicsClientId=self._client)
        return JointStates(self._wheel_names, tuple(s[0] for s in states), tuple(s[1] for s in states))

    def close(self) -> None:
        self._finalizer()

    def __enter__(self) -> SimplebotSim:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _disconnect(client: int) -> None:
    if pb.isConnected(physicsClientId=client):
        pb.disconnect(physicsClientId=client)


def _obstacle_mesh(world: World) -> tuple[list, list]:
    """All obstacles as closed prisms in one triangle soup (vertices, indices) for the ray mesh."""
    vertices: list[list[float]] = []
    indices: list[int] = []
    for _, shape in world.obstacles():
        cx, cy = shape.center
        if isinstance(shape, Box):
            outline = shape.corners()
        else:
            # Vertices pushed out so the polygon's mean radius equals the cylinder's (error < 0.07 %).
            n = _CYLINDER_SIDES
            r = shape.radius * 2 / (1 + math.cos(math.pi / n))
            outline = [(cx + r * math.cos(2 * math.pi * k / n), cy + r * math.sin(2 * math.pi * k / n))
                       for k in range(n)]
        base, n = len(vertices), len(outline)
        vertices += [[x, y, 0.0] for x, y in outline] + [[x, y, shape.height] for x, y in outline]
        for i in range(n):
            j = (i + 1) % n
            indices += [base + i, base + j, base + n + j, base + i, base + n + j, base + n + i]
        for i in range(1, n - 1):
            indices += [base, base + i + 1, base + i, base + n, base + n + i, base + n + i + 1]
    return vertices, indices
