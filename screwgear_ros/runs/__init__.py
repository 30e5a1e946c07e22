"""Runs of table_sim as rosbag2/MCAP bags: recording, reading, offline check, replay.

Nothing here imports rclpy: the node hands :class:`RunRecorder` its messages and a
serializer, and the readers decode CDR with the ROS 2 Jazzy typestore of ``rosbags``.
The bag contract (topics, log times, parameters) is described in ``docs/recording.md``.
"""

from .recorder import RunRecorder, TopicSpec

__all__ = ['RunRecorder', 'TopicSpec']
