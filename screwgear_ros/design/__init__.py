"""Controller design from the model, with no ROS: a linear model of the 3-DOF table at an
operating point (:mod:`.linearize`) and its frequency response measured by simulation
(:mod:`.frequency`)."""

from .linearize import (
    INPUTS,
    OUTPUTS,
    STATES,
    LinearModel,
    ModeInfo,
    OperatingPoint,
    OperatingPointError,
    linearize,
    operating_point,
)

__all__ = ['INPUTS', 'OUTPUTS', 'STATES', 'LinearModel', 'ModeInfo', 'OperatingPoint',
           'OperatingPointError', 'linearize', 'operating_point']
