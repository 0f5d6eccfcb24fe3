"""move_base's decision logic (state machine, recoveries), free of ROS."""
