"""ROS 2 shell of the node (imports rclpy): the node and its pacing thread, parameters,
messages, inputs, recording I/O, the replay client, the URDF and markers, launch support."""
