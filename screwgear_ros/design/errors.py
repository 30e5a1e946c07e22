"""What the design tools refuse, or cannot do, each kind its own class.

All derive from :class:`DesignError` (a :class:`~screwgear_ros.errors.ScrewgearError` and a
``ValueError``), so a caller that handles every refusal the same way catches that one; a
caller that tells them apart catches the class that names the mistake.

Examples
--------
>>> from screwgear_ros.design.errors import DesignError, UnknownOutput
>>> issubclass(UnknownOutput, DesignError) and issubclass(UnknownOutput, ValueError)
True
"""

from __future__ import annotations

from ..errors import ScrewgearError


class DesignError(ScrewgearError, ValueError):
    """Base of what linearizing or measuring a frequency response refuses; says why."""


class OperatingPointRefused(DesignError):
    """A torque, load or direction of the operating point the node would refuse (not a
    finite number, out of its range)."""


class NoSteadyState(DesignError):
    """The inputs are valid but the model has no steady motion or rest under them, or its
    solver found none."""


class MeshModelUnsupported(DesignError):
    """The mesh model asked for does not apply at this operating point (a frozen mesh
    while the mesh phase advances)."""


class UnknownOutput(DesignError):
    """An output name that is not one of :data:`~screwgear_ros.design.linear_model.OUTPUTS`."""


class MeasurementRefused(DesignError):
    """A measurement setting it cannot honour: amplitude, frequencies, or an input the
    operating point does not respond to."""


class MeasurementFailed(DesignError):
    """The simulated measurement ran but the node refused some of its input commands."""


class UsageError(DesignError):
    """A command-line argument of the design tools that cannot be used as given."""


__all__ = [
    'DesignError',
    'MeasurementFailed',
    'MeasurementRefused',
    'MeshModelUnsupported',
    'NoSteadyState',
    'OperatingPointRefused',
    'UnknownOutput',
    'UsageError',
]
