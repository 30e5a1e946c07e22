"""What is done with a run and its recording: the node's messages of a session, published
and recorded (:mod:`.run_io`), an in-process recording (:mod:`.session_record`); and
with a recorded run: check it against the reference solution, compare a replay with its
original, plot it, and replay it in-process through a session.

Nothing here imports rclpy; writing and reading bags is :mod:`screwgear_ros.bag`.
"""

from __future__ import annotations

import warnings
from typing import Any


def __getattr__(name: str) -> Any:
    if name in ('RunRecorder', 'TopicSpec'):
        warnings.warn(f'screwgear_ros.runs.{name} moved to screwgear_ros.bag.{name}; the old '
                      'path goes in the next release', DeprecationWarning, stacklevel=2)
        from .. import bag
        return getattr(bag, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
