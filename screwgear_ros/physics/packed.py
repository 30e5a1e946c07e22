"""The packed form of the 3-DOF double screw gear model of ``shared/spec/model.md``: the
state, the input and the parameters as the compiled kernels take them.

State y = (θ1, θ2, θ3, ω1, ω2, ω3): pinion 1, table, pinion 3 angles in rad and
speeds in rad/s, pinion angles counted in the sense that drives the table forward.
Input u = (torque, direction, load): drive torque magnitude T ≥ 0 in N·m on the
active pinion, direction d = ±1, external table load T_load in N·m.

The drives' current loops add two states (:data:`N_STATE` in all): y[6] and y[7], the
torque the drive of pinion 1 and of pinion 3 applies besides the preload (N·m, signed in
the sense that drives the table forward), each lagging its command with the time
constant τ_d (``drive_time_constant``). With τ_d = 0 they stay 0 and are not used: the
command acts at once.

The kernels (:mod:`.mesh`, :mod:`.drive`, :mod:`.motion`) are scalar and compiled with
numba (``NUMBA_DISABLE_JIT=1`` runs the same source as plain Python). What the equations
of motion take travels as named tuples, each declared once, and passed whole through the
integrators, so a new parameter array, input or held piece is one field of one tuple
rather than a parameter of every kernel: the model (:class:`PackedModel`, from
:func:`pack`: one packed float array and the STE harmonics, so the compiled code sees no
Python objects), the drive input (:class:`Drive`) and the pieces of the law a step holds
(:class:`~screwgear_ros.physics.motion.Pieces`). The state y is a tuple of :data:`N_STATE`
floats.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..params.declarations import kernel_fields
from ..params.table import (
    MeshFormulation,
    MeshPhase,
    Mode,
    TableParams,
    effective_stiffness,
)

# Layout of the packed parameter array: the kernel=True fields of TableParams in their
# declaration order, then three derived slots. Looking the indices up by name means a
# field the kernel uses cannot be left out of pack() (the import would fail).
KERNEL = kernel_fields(TableParams)
_AT = {name: index for index, name in enumerate(KERNEL)}
I1, I2, I3 = _AT['inertia_pinion_1'], _AT['inertia_table'], _AT['inertia_pinion_3']
R1, R2, R3 = _AT['radius_pinion_1'], _AT['radius_table'], _AT['radius_pinion_3']
Z1, Z3 = _AT['teeth_pinion_1'], _AT['teeth_pinion_3']
K_A, PHI_K = _AT['mesh_stiffness_amplitude'], _AT['mesh_stiffness_phase']
C, B, TP = _AT['mesh_damping'], _AT['backlash'], _AT['preload_torque']
TV, WV = _AT['torque_fluctuation_amplitude'], _AT['torque_fluctuation_frequency']
CT, WE = _AT['table_damping'], _AT['mesh_frequency']
WNL, TS = _AT['drive_no_load_speed'], _AT['drive_stall_torque']
TC2, TS2, WS2 = (_AT['table_coulomb_torque'], _AT['table_static_torque'],
                 _AT['table_stribeck_speed'])
TCP, TSP, WSP, CP = (_AT['pinion_coulomb_torque'], _AT['pinion_static_torque'],
                     _AT['pinion_stribeck_speed'], _AT['pinion_damping'])
TAU, TCOG, NCOG = (_AT['drive_time_constant'], _AT['cogging_amplitude'],
                   _AT['cogging_order'])
K_EFF, MODE, PHASE, FORMULATION = range(len(KERNEL), len(KERNEL) + 4)   # derived: k_eff, enums
N_PACKED = len(KERNEL) + 4

#: Length of the state: θ1, θ2, θ3, ω1, ω2, ω3, then the lagged drive torques L1, L3.
N_STATE = 8
#: Of it, the mechanical state (what joint_states carries and a recording starts from).
N_MECHANICAL = 6

MODE_ANTI_BACKLASH = 0.0
MODE_CONVENTIONAL = 1.0
PHASE_ANGLE = 0.0
PHASE_TIME = 1.0
FORM_PAPER = 0.0
FORM_ENERGY = 1.0


class PackedModel(NamedTuple):
    """What the compiled code needs: packed scalars and the STE harmonic arrays. A tuple,
    so the kernels take it whole."""

    p: np.ndarray          # float64[N_PACKED]
    ste_amp: np.ndarray    # ε_n, m
    ste_phase: np.ndarray  # ϕ_n, rad


class Drive(NamedTuple):
    """The input as the compiled code takes it: drive torque T ≥ 0 (N·m), direction ±1,
    table load T_load (N·m), all floats."""

    torque: float
    direction: float
    load: float


def pack(params: TableParams) -> PackedModel:
    """Pack validated parameters for the compiled model."""
    p = np.zeros(N_PACKED)
    p[:len(KERNEL)] = [getattr(params, name) for name in KERNEL]
    p[K_EFF] = effective_stiffness(params)
    p[MODE] = MODE_CONVENTIONAL if params.mode is Mode.CONVENTIONAL else MODE_ANTI_BACKLASH
    p[PHASE] = PHASE_TIME if params.mesh_phase is MeshPhase.TIME else PHASE_ANGLE
    p[FORMULATION] = (FORM_ENERGY if params.mesh_formulation is MeshFormulation.ENERGY_CONSISTENT
                      else FORM_PAPER)
    return PackedModel(p, np.array(params.ste_amplitudes, dtype=np.float64),
                       np.array(params.ste_phases, dtype=np.float64))


__all__ = [
    'CP',
    'CT',
    'FORMULATION',
    'FORM_ENERGY',
    'FORM_PAPER',
    'I1',
    'I2',
    'I3',
    'KERNEL',
    'K_A',
    'K_EFF',
    'MODE',
    'MODE_ANTI_BACKLASH',
    'MODE_CONVENTIONAL',
    'NCOG',
    'N_MECHANICAL',
    'N_PACKED',
    'N_STATE',
    'PHASE',
    'PHASE_ANGLE',
    'PHASE_TIME',
    'PHI_K',
    'R1',
    'R2',
    'R3',
    'TAU',
    'TC2',
    'TCOG',
    'TCP',
    'TP',
    'TS',
    'TS2',
    'TSP',
    'TV',
    'WE',
    'WNL',
    'WS2',
    'WSP',
    'WV',
    'Z1',
    'Z3',
    'B',
    'C',
    'Drive',
    'PackedModel',
    'pack',
]
