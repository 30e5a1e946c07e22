"""Controller design from the model, with no ROS: a linear model of the 3-DOF table at an
operating point (:mod:`.linearize`, :mod:`.operating_point`, :mod:`.linear_model`), in a
named bearing-friction state (:mod:`.friction_state`), with the sensor and drive dynamics
a parameter file declares (:mod:`.loop_dynamics`), and its frequency response measured by
simulation (:mod:`.frequency`); what they refuse, :mod:`.errors`."""

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
from .friction_state import FrictionState, FrictionUndefined, linearize_with_friction
from .linear_model import INPUTS, OUTPUTS, STATES, LinearModel, ModeInfo
from .linearize import linearize
from .loop_dynamics import declares_dynamics, with_dynamics
from .operating_point import OperatingPoint, operating_point

__all__ = ['INPUTS', 'OUTPUTS', 'STATES', 'DesignError', 'FrictionState',
           'FrictionUndefined', 'LinearModel', 'MeasurementFailed', 'MeasurementRefused',
           'MeshModelUnsupported', 'ModeInfo', 'NoSteadyState', 'OperatingPoint',
           'OperatingPointRefused', 'UnknownOutput', 'UsageError', 'declares_dynamics',
           'linearize', 'linearize_with_friction', 'operating_point', 'with_dynamics']
