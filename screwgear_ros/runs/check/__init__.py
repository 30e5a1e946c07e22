"""Check a recorded run against the reference solution of its own inputs.

The model is rebuilt from the bag's run_parameters; the recorded inputs, parameter
changes and resets are re-integrated with the DOP853 reference solver
(:mod:`screwgear_ros.numerics.reference`: compiled Dormand–Prince 8(5,3), adaptive, rtol 1e-11),
restarted at every change, and the recorded joint states (θ, ω, effort of every joint),
transmission error and mesh_state (δ, δ̇, F of both meshes, the plant's outputs of the
reference state) are compared with it at every recorded sample; the recorded
active_path must change where the in-process replay changes it. A run whose joint
sensors are not all ideal records the exact state on ``~/true_joint_states``: the
physics is judged on it, and the recorded joint_states must then follow from it by the
recorded sensor model (:mod:`screwgear_ros.physics.sensors`, its noise included) bit for bit.
A run the reference cannot follow raises :class:`~screwgear_ros.numerics.reference.ReferenceFailure`
(why, at what simulation time, in which segment of the run); one with nothing to
compare raises :class:`NothingToCompare`.

The tolerances are :mod:`.tolerance`'s, the reference :mod:`.reference`'s, the verdict
:mod:`.verdict`'s.
"""

from __future__ import annotations

from .reference import mesh_of, reference_outputs, signal_names
from .tolerance import (
    FLOOR_ABS,
    FLOOR_REL,
    REFERENCE_REFINE,
    SAFETY,
    SAFETY_FIXED_STEP,
    TABLE_ENCODER_BITS,
    TABLE_ENCODER_COUNT,
    SignalError,
    signal_error,
)
from .verdict import (
    MESH_SIGNALS,
    CheckReport,
    NothingToCompare,
    check_run,
    format_report,
    path_changes,
    require_samples,
    sensor_mismatch,
    sensor_rows,
)

__all__ = [
    'FLOOR_ABS',
    'FLOOR_REL',
    'MESH_SIGNALS',
    'REFERENCE_REFINE',
    'SAFETY',
    'SAFETY_FIXED_STEP',
    'TABLE_ENCODER_BITS',
    'TABLE_ENCODER_COUNT',
    'CheckReport',
    'NothingToCompare',
    'SignalError',
    'check_run',
    'format_report',
    'mesh_of',
    'path_changes',
    'reference_outputs',
    'require_samples',
    'sensor_mismatch',
    'sensor_rows',
    'signal_error',
    'signal_names',
]

