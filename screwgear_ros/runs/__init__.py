"""What is done with a run and its recording: the node's messages of a session, published
and recorded (:mod:`.run_io`), an in-process recording (:mod:`.session_record`); and
with a recorded run: check it against the reference solution, compare a replay with its
original, plot it, and replay it in-process through a session.

Nothing here imports rclpy; writing and reading bags is :mod:`screwgear_ros.bag`.
"""
