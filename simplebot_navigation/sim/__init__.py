"""Pure simulator core (no ROS): pybullet simplebot, diff drive, lidars, world files."""

from .diff_drive import DiffDriveParams, OdomNoise
from .lidar import LaserScanData
from .simulator import CollisionReport, JointStates, Odometry, SimplebotSim
from .world import Box, Cylinder, Pose2D, Wall, World, world_from_dict, write_world
from .world_gen import clutter_world, door_goal_name, doors_world
from .world_loader import load_world

__all__ = [
    "Box",
    "CollisionReport",
    "Cylinder",
    "DiffDriveParams",
    "JointStates",
    "LaserScanData",
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
