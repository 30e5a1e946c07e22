"""Calibrate the table model to recordings: :func:`identify` fits the plant's parameters
to joint_states and commands recorded from table_sim or a real table (output error).

``screwgear_ros.identify`` is both this package and the function: the package's module
object is callable, ``screwgear_ros.identify(bags, params, fit, ...)`` calls
:func:`~screwgear_ros.identify.api.identify`, whichever of the two an import made the
attribute.

Examples
--------
>>> import screwgear_ros
>>> callable(screwgear_ros.identify)
True
"""

from __future__ import annotations

import sys
import types
from typing import Any

from .api import IdentifyResult, identify
from .errors import FitParameterError, IdentifyError, RecordingError, TooShortError


class _CallableModule(types.ModuleType):
    def __call__(self, *args: Any, **kwargs: Any) -> IdentifyResult:
        return identify(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

__all__ = ['FitParameterError', 'IdentifyError', 'IdentifyResult', 'RecordingError',
           'TooShortError', 'identify']
