"""Runs as rosbag2 bags with MCAP storage: the fixed format, CDR serialization, the
recorder that writes a run off the real-time path, and the reader that gives it back.

Nothing here imports rclpy: the node hands :class:`RunRecorder` its messages and a
serializer, and the reader decodes CDR with the ROS 2 Jazzy typestore of ``rosbags``.
The bag contract (topics, log times, parameters) is described in ``docs/recording.md``.
"""

from .recorder import RunRecorder, TopicSpec

__all__ = ['RunRecorder', 'TopicSpec']
