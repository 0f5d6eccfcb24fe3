"""Pure simulator core (no ROS): pybullet simplebot, diff drive, lidars, world files."""

from simplebot_navigation.sim.diff_drive import DiffDriveParams, OdomNoise
from simplebot_navigation.sim.lidar import LaserScanData
from simplebot_navigation.sim.moving import MovingObstacle, MovingObstacleState, MovingTracks
from simplebot_navigation.sim.simulator import CollisionReport, JointStates, Odometry, SimplebotSim
from simplebot_navigation.sim.world import Box, Cylinder, Pose2D, Wall, World, world_from_dict, write_world
from simplebot_navigation.sim.world_gen import clutter_world, door_goal_name, doors_world
from simplebot_navigation.sim.world_loader import load_world

__all__ = [
    "Box",
    "CollisionReport",
    "Cylinder",
    "DiffDriveParams",
    "JointStates",
    "LaserScanData",
    "MovingObstacle",
    "MovingObstacleState",
    "MovingTracks",
    "OdomNoise",
    "Odometry",
    "Pose2D",
    "SimplebotSim",
    "Wall",
    "World",
    "clutter_world",
    "door_goal_name",
    "doors_world",
    "load_world",
    "world_from_dict",
    "write_world",
]
