"""Controller design from the model, with no ROS: a linear model of the 3-DOF table at an
operating point (:mod:`.linearize`, :mod:`.operating_point`, :mod:`.linear_model`) and its
frequency response measured by simulation (:mod:`.frequency`); what they refuse,
:mod:`.errors`."""

from __future__ import annotations

from .errors import (
    DesignError,
    MeasurementFailed,
    MeasurementRefused,
    MeshModelUnsupported,
    NoSteadyState,
    OperatingPointRefused,
    UnknownOutput,
    UsageError,
)
from .linear_model import INPUTS, OUTPUTS, STATES, LinearModel, ModeInfo
from .linearize import linearize
from .operating_point import OperatingPoint, operating_point

__all__ = ['INPUTS', 'OUTPUTS', 'STATES', 'DesignError', 'LinearModel', 'MeasurementFailed',
           'MeasurementRefused', 'MeshModelUnsupported', 'ModeInfo', 'NoSteadyState',
           'OperatingPoint', 'OperatingPointRefused', 'UnknownOutput', 'UsageError',
           'linearize', 'operating_point']
