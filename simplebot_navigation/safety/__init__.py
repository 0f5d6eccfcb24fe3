"""What stops the robot whatever the planner does: the collision monitor's judgement (no rclpy)."""
