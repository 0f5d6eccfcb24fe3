"""Costmap2DROS: a costmap's ROS shell, its sensor and map input, its publishers and its log."""
