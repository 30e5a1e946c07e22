"""The imperative shell: the node and command-line tools (these import rclpy where needed)."""
