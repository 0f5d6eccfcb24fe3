"""Localization on a known map: ROS 1 amcl's particle filter, motion and laser models (docs/reference.md §8)."""

from simplebot_navigation.localization.amcl import Amcl
from simplebot_navigation.localization.amcl_params import AmclParams
from simplebot_navigation.localization.clusters import PoseEstimate, covariance_from_ros, covariance_to_ros
from simplebot_navigation.localization.laser_models import RangeScan

__all__ = ["Amcl", "AmclParams", "PoseEstimate", "RangeScan", "covariance_from_ros", "covariance_to_ros"]
