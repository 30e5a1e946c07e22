"""Runs as rosbag2 bags with MCAP storage: the fixed format, CDR serialization, the
recorder that writes a run off the real-time path, and the reader that gives it back.

Nothing here imports rclpy: every message a run records is CDR written here
(:mod:`.cdr` templates for the per-tick outputs, :mod:`.messages` for the rest), handed
to :class:`RunRecorder` as bytes, and the reader decodes CDR with the ROS 2 Jazzy
typestore of ``rosbags``.
The bag contract (topics, log times, parameters) is described in ``docs/recording.md``.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .recorder import RunRecorder, TopicSpec

#: Loaded on first use: the node's start encodes messages with :mod:`.cdr` and must not
#: pay for the recorder's MCAP and compression libraries until it records.
_LAZY = {'RunRecorder': '.recorder', 'TopicSpec': '.recorder'}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    return getattr(import_module(module, __name__), name)


__all__ = ['RunRecorder', 'TopicSpec']
