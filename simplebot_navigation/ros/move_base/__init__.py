"""move_base's node: the state machine's shell, its goals, parameters, recoveries, statistics and
supervision, and the ROS wrappers of its planners."""
