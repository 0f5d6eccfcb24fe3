"""A pip-installable re-implementation of the ROS 1 move_base navigation stack for ROS 2 Jazzy."""

__version__ = "0.1.0"
