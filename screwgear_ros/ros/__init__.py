"""ROS 2 glue of the node shell: parameters and messages (imports rclpy)."""
