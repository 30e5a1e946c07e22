"""Calibrate the table model to recordings: :func:`identify` fits the plant's parameters
to joint_states and commands recorded from table_sim or a real table (output error).

The function is also ``screwgear_ros.identify``; the ``identify`` executable is its
command line (:mod:`screwgear_ros.cli.identify`).
"""

from __future__ import annotations

from .api import IdentifyResult, identify
from .errors import FitParameterError, IdentifyError, RecordingError, TooShortError

__all__ = ['FitParameterError', 'IdentifyError', 'IdentifyResult', 'RecordingError',
           'TooShortError', 'identify']
