"""The pybullet simplebots: physics, diff drive, wheel odometry, lidars and contacts, without ROS.

One instance owns one pybullet DIRECT client, so several simulators can live in one process, and one
or more robots (sim/robot.py), which see and bump into each other. Time
advances only through step()/step_until(); with the same world, commands and seed every run is
identical.

Physics runs at 100 Hz by default: the robot is slow (1.05 m/s; 2 m/s with the round body's Jackal
drive: at most 2 cm per step, no tunnelling through 0.1 m walls) and rests on rigid wheels and casters,
which Bullet's solver keeps stable at 10 ms steps (odometry and ground truth agree to a millimetre over
metres of driving); 100 Hz divides the 10 Hz lidars and the usual 20/50 Hz controller and odometry rates,
and is cheaper than Bullet's customary 240 Hz, though not 2.4x: the lidar rays dominate the cost
(bench/sim_speed.py).

Obstacles exist twice: as primitives (boxes, cylinders) for contacts, and merged into one static
triangle mesh that only the lidar rays see (collision filter groups keep the two apart). Ray casts
against a BVH mesh cost half of those against convex primitives, and the robot itself is not in the
ray group, so a scan can never see its own body. Other robots are seen through their hulls, each in a
filter group of its own that the robot's own casts leave out of their mask.

Moving obstacles (world ``moving:``, sim/moving.py) are primitives of their own group, which the robots
collide with; before every physics step each is put where its keyframes say it is at the step's end
(kinematic: nothing pushes them, they push the robots). The lidars meet them in closed form after each
ray batch (MovingTracks.ray_fractions: Bullet's casts against convex primitives cost ten times more).
A robot's collision counts as "moving" or "standing" by whether it drove itself recently (sim/robot.py).
"""

from __future__ import annotations

import dataclasses
import math
import weakref
from typing import Sequence

import numpy as np
import pybullet as pb

from simplebot_description import RobotDescription

from simplebot_navigation.sim.diff_drive import DiffDriveParams, OdomNoise
from simplebot_navigation.sim.lidar import LaserScanData
from simplebot_navigation.sim.moving import MovingObstacle, MovingObstacleState, MovingTracks, obstacle_label
from simplebot_navigation.sim.robot import CollisionGroups, CollisionReport, JointStates, Odometry, SimRobot
from simplebot_navigation.sim.world import Box, Cylinder, Pose2D, World, check_poses_clear

# Collision filter groups. Bullet lets a ray hit an object only if the object's mask has bit 1
# (the ray's own group), so only the ray mesh and the robots' hulls carry that bit.
_RAY = 1
_ROBOT = 2
_FLOOR = 4
_OBSTACLE = 8
_RAY_MESH = 16
_MOVING = 32
_FIRST_HULL = 64
#: robots in one world: each hull takes a filter group bit of Bullet's 32
MAX_ROBOTS = 16
#: moving obstacles further than this from touching a robot are parked at _PARKED_Z, below the floor
_CONTACT_MARGIN = 0.5
_PARKED_Z = -50.0
_CYLINDER_SIDES = 64


class SimplebotSim:
    """Simulated simplebots in one world.

    The ROS node calls set_cmd_vel() when a Twist arrives, step_until() to advance the clock, and
    publishes odometry(), ground_truth(), due_scans() and collisions(); each takes the robot's index
    (0, the only one unless ``starts`` lists more poses than the world's start).

    physics_rate must be a multiple of the lidar rate (10 Hz). ``seed`` feeds the lidar range noise
    (``range_noise_std``, metres, off by default) and the odometry errors (``odom_noise``, off by
    default). ``ray_threads`` is passed to rayTestBatch (1: the other core stays free for the nodes).
    A start's ``name`` labels that robot in the other robots' collision reports.
    """

    def __init__(self, world: World, description: RobotDescription, *, physics_rate: float = 100.0,
                 seed: int = 0, drive: DiffDriveParams = DiffDriveParams(),
                 range_noise_std: float = 0.0, odom_noise: OdomNoise | None = None,
                 ray_threads: int = 1, starts: Sequence[Pose2D] | None = None):
        if isinstance(physics_rate, bool) or not isinstance(physics_rate, (int, float)) \
                or not math.isfinite(physics_rate) or physics_rate <= 0:
            raise ValueError(f"physics_rate must be a positive number of Hz, got {physics_rate!r}")
        if isinstance(seed, bool) or not isinstance(seed, int):
            raise ValueError(f"seed must be an int, got {seed!r}")
        starts = (world.start,) if starts is None else tuple(starts)
        if not 1 <= len(starts) <= MAX_ROBOTS:
            raise ValueError(f"starts: one pose per robot, 1 to {MAX_ROBOTS} robots, got {len(starts)}")
        self.world = world
        self.description = description
        self.physics_rate = float(physics_rate)
        self.dt = 1.0 / self.physics_rate
        self.drive = drive
        self._ray_threads = ray_threads
        self._scan_period_steps = []
        for sensor in description.scans.values():
            ratio = self.physics_rate / sensor.update_rate
            if abs(ratio - round(ratio)) > 1e-9:
                raise ValueError(f"physics_rate {physics_rate} Hz must be a multiple of the {sensor.frame} "
                                 f"update rate {sensor.update_rate} Hz")
            self._scan_period_steps.append(round(ratio))

        self._client = pb.connect(pb.DIRECT)
        self._finalizer = weakref.finalize(self, _disconnect, self._client)
        self._steps = 0
        self._build()
        hulls = [_FIRST_HULL << i for i in range(len(starts))]
        # The first robot draws its noise from the seed as a lone robot always did.
        seeds = [np.random.SeedSequence(seed)] + [np.random.SeedSequence([seed, i]) for i in range(1, len(starts))]
        self.robots = [SimRobot(self._client, description, start,
                                CollisionGroups(_ROBOT, _FLOOR | _OBSTACLE | _MOVING | _ROBOT, hull), drive=drive,
                                range_noise_std=range_noise_std, odom_noise=odom_noise, seed=robot_seed)
                       for start, hull, robot_seed in zip(starts, hulls, seeds)]
        all_hulls = sum(hulls)
        self._ray_masks = [_RAY_MESH | (all_hulls & ~hull) for hull in hulls]
        for i, robot in enumerate(self.robots):
            self._labels[robot.body] = robot.start.name or f"robots[{i}]"

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

        self._labels: dict[int, str] = {}
        for label, shape in self.world.obstacles():
            body = self._create_obstacle(shape)
            pb.setCollisionFilterGroupMask(body, -1, _OBSTACLE, _ROBOT, physicsClientId=c)
            self._labels[body] = f"{label} ({shape.name})" if shape.name else label
        vertices, indices = _obstacle_mesh(self.world)
        if indices:
            mesh = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, indices=indices, physicsClientId=c)
            self._ray_mesh = pb.createMultiBody(0, mesh, physicsClientId=c)
            pb.setCollisionFilterGroupMask(self._ray_mesh, -1, _RAY_MESH, _RAY, physicsClientId=c)
        self._build_moving()

    def _build_moving(self) -> None:
        """One body per moving obstacle, at its place at time 0, for contacts with the robots."""
        c = self._client
        self._tracks = MovingTracks(self.world.moving)
        self._moving_xy = self._tracks.states(0.0)[:, :2]
        self._moving_bodies = []
        self._placed = np.ones(len(self.world.moving), dtype=bool)
        # Obstacle centres nearer to a robot's centre than this are placed for contacts.
        self._contact_reach = self._tracks.reach + self.description.circumscribed_radius + _CONTACT_MARGIN
        for i, (obstacle, (x, y)) in enumerate(zip(self.world.moving, self._moving_xy)):
            body = self._create_obstacle(_moving_shape(obstacle, x, y))
            pb.setCollisionFilterGroupMask(body, -1, _MOVING, _ROBOT, physicsClientId=c)
            self._labels[body] = obstacle_label(i, obstacle)
            self._moving_bodies.append((body, obstacle.height / 2))

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

    def set_cmd_vel(self, v: float, w: float, now: float | None = None, robot: int = 0) -> None:
        """Command body velocity (m/s, rad/s), received at sim time ``now`` (default: current).

        Raises ValueError for NaN/inf; the previous command then stays in force (and times out).
        """
        self.robots[robot].set_cmd_vel(v, w, self.sim_time if now is None else now)

    def kidnap(self, pose: Pose2D, robot: int = 0) -> None:
        """Teleport a robot to ``pose`` in the world frame without telling its odometry; a pose inside an
        obstacle is a ValueError."""
        check_poses_clear(self.world, [("kidnap pose", pose)], self.description.inscribed_radius)
        self.robots[robot].kidnap(pose)

    def set_moving_keyframes(self, index: int, keyframes: Sequence[Sequence[float]]) -> None:
        """Give moving obstacle ``index`` (of the world's ``moving:``) new keyframes ((t, x, y), t in sim time),
        from the next physics step on: an obstacle that appears where a robot is, at a moment a test chooses
        while it runs. Its shape and size stay. IndexError for an unknown index, MovingObstacleError for bad
        keyframes (the world's rules); either way the old track stays."""
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(self.world.moving):
            raise IndexError(f"no moving obstacle {index!r}; the world has {len(self.world.moving)}")
        moving = list(self.world.moving)
        moving[index] = dataclasses.replace(moving[index], keyframes=tuple(tuple(float(v) for v in frame)
                                                                           for frame in keyframes))
        self.world = dataclasses.replace(self.world, moving=tuple(moving))
        self._tracks = MovingTracks(self.world.moving)

    def step(self) -> None:
        """Advance one physics step: drive control, physics, odometry, contacts, due scans."""
        now = self.sim_time
        for robot in self.robots:
            robot.before_step(now, self.dt)
        if self._moving_bodies:
            self._move_obstacles((self._steps + 1) / self.physics_rate)
        pb.stepSimulation(physicsClientId=self._client)
        self._steps += 1
        now = self.sim_time
        for robot in self.robots:
            robot.after_step(now, self.dt, self._labels, self._floor)
        due = [i for i, period in enumerate(self._scan_period_steps) if self._steps % period == 0]
        if due:
            self._cast(due)

    def _move_obstacles(self, t: float) -> None:
        """Put the moving obstacles near a robot where they are at sim time t, and park the others below
        the floor (out of every contact): moving a body costs a pybullet call, and contacts happen only
        near robots. The lidars and the ground truth take the places from the tracks, not the bodies."""
        xy = self._tracks.states(t)[:, :2]
        near = np.zeros(len(xy), dtype=bool)
        for robot in self.robots:
            rx, ry, _ = pb.getBasePositionAndOrientation(robot.body, physicsClientId=self._client)[0]
            near |= np.hypot(xy[:, 0] - rx, xy[:, 1] - ry) < self._contact_reach
        place = near & ((xy != self._moving_xy).any(axis=1) | ~self._placed)
        park = ~near & self._placed
        for i in np.flatnonzero(place | park).tolist():
            body, z = self._moving_bodies[i]
            pb.resetBasePositionAndOrientation(body, (*xy[i].tolist(), z if near[i] else _PARKED_Z),
                                               (0.0, 0.0, 0.0, 1.0), physicsClientId=self._client)
        self._moving_xy, self._placed = xy, near

    def step_until(self, t: float) -> None:
        """Step while the next step ends at or before sim time t."""
        while (self._steps + 1) / self.physics_rate <= t + 1e-9:
            self.step()

    def _cast(self, sensors: list[int]) -> None:
        """One batch of rays per robot, against the obstacles and the other robots' hulls."""
        if len(self.robots) > 1:
            for robot in self.robots:
                robot.move_hull()
        for robot, mask in zip(self.robots, self._ray_masks):
            origins, ends = robot.lidars.rays(sensors, *robot.base_link_pose())
            results = pb.rayTestBatch(origins, ends, numThreads=self._ray_threads, collisionFilterMask=mask,
                                      physicsClientId=self._client)
            ids, _, fractions, _, _ = zip(*results)
            hit, fractions = np.asarray(ids) >= 0, np.asarray(fractions)
            if self._moving_bodies:
                moving = self._tracks.ray_fractions(origins, ends, self._moving_xy)
                closer = moving < np.where(hit, fractions, np.inf)
                fractions, hit = np.where(closer, moving, fractions), hit | closer
            robot.add_scans(robot.lidars.scans(sensors, fractions, hit, self.sim_time))

    # -- outputs ------------------------------------------------------------------------------

    def odometry(self, robot: int = 0) -> Odometry:
        """Wheel odometry: base_link in the odom frame (the robot's start pose), twist in base_link."""
        return self.robots[robot].odometry(self.sim_time)

    def ground_truth(self, robot: int = 0) -> Odometry:
        """True base_link pose in the world frame and its twist in base_link."""
        return self.robots[robot].ground_truth(self.sim_time)

    def due_scans(self, robot: int = 0) -> list[LaserScanData]:
        """Scans taken since the last call, oldest first."""
        return self.robots[robot].due_scans()

    def collisions(self, robot: int = 0) -> CollisionReport:
        return self.robots[robot].collisions()

    def moving_obstacle_states(self) -> list[MovingObstacleState]:
        """Ground truth of the moving obstacles now, in the world frame, in the order of world.moving."""
        return [MovingObstacleState(obstacle_label(i, o), o.shape, *row, o.extent())
                for i, (o, row) in enumerate(zip(self.world.moving, self._tracks.states(self.sim_time).tolist()))]

    def joint_states(self, robot: int = 0) -> JointStates:
        """Wheel angles and speeds (for /joint_states and the wheels' transforms)."""
        return self.robots[robot].joint_states()

    def close(self) -> None:
        self._finalizer()

    def __enter__(self) -> SimplebotSim:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _disconnect(client: int) -> None:
    if pb.isConnected(physicsClientId=client):
        pb.disconnect(physicsClientId=client)


def _moving_shape(obstacle: MovingObstacle, x: float, y: float) -> Box | Cylinder:
    if obstacle.shape == "box":
        return Box((x, y), obstacle.size, 0.0, obstacle.height)
    return Cylinder((x, y), obstacle.radius, obstacle.height)


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
