"""amcl's ROS node: localization.Amcl behind amcl's topics, frames and services."""
