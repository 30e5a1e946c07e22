"""Old home of the model's names, kept for one release: each name now lives in the module
of its job (:mod:`.packed`, :mod:`.mesh`, :mod:`.drive`, :mod:`.motion`,
:mod:`.equilibrium`), and reading it here gives that very object with a
:class:`DeprecationWarning` naming the new module.
"""

from __future__ import annotations

import importlib
import warnings

#: Name -> the module of ``screwgear_ros.physics`` it moved to.
MOVED_NAMES: dict[str, str] = {
    'B': 'packed',
    'BY_LAW': 'motion',
    'C': 'packed',
    'CP': 'packed',
    'CT': 'packed',
    'ContactBranch': 'mesh',
    'Drive': 'packed',
    'DrivePiece': 'drive',
    'EquilibriumNotFound': 'equilibrium',
    'FORMULATION': 'packed',
    'FORM_ENERGY': 'packed',
    'FORM_PAPER': 'packed',
    'I1': 'packed',
    'I2': 'packed',
    'I3': 'packed',
    'KERNEL': 'packed',
    'K_A': 'packed',
    'K_EFF': 'packed',
    'MODE': 'packed',
    'MODE_ANTI_BACKLASH': 'packed',
    'MODE_CONVENTIONAL': 'packed',
    'NCOG': 'packed',
    'NEWTON_ITERATIONS': 'equilibrium',
    'N_MECHANICAL': 'packed',
    'N_PACKED': 'packed',
    'N_STATE': 'packed',
    'PHASE': 'packed',
    'PHASE_ANGLE': 'packed',
    'PHASE_TIME': 'packed',
    'PHI_K': 'packed',
    'PackedModel': 'packed',
    'Pieces': 'motion',
    'R1': 'packed',
    'R2': 'packed',
    'R3': 'packed',
    'TAU': 'packed',
    'TC2': 'packed',
    'TCOG': 'packed',
    'TCP': 'packed',
    'TP': 'packed',
    'TS': 'packed',
    'TS2': 'packed',
    'TSP': 'packed',
    'TV': 'packed',
    'WE': 'packed',
    'WNL': 'packed',
    'WS2': 'packed',
    'WSP': 'packed',
    'WV': 'packed',
    'Z1': 'packed',
    'Z3': 'packed',
    'active_path': 'drive',
    'active_speed': 'drive',
    'applied_torques': 'drive',
    'applied_torques_on': 'drive',
    'body_torques': 'motion',
    'branch_force': 'mesh',
    'branch_penetration': 'mesh',
    'cogging': 'drive',
    'contact_branch': 'mesh',
    'contact_branches': 'motion',
    'drive_on': 'drive',
    'drive_piece': 'drive',
    'drive_targets': 'drive',
    'drive_torques': 'drive',
    'effort_and_meshes': 'motion',
    'equilibrium_state': 'equilibrium',
    'friction_pieces': 'motion',
    'lag_rates': 'drive',
    'lag_state': 'drive',
    'lagged_torques': 'drive',
    'mesh_force': 'mesh',
    'mesh_load_on': 'mesh',
    'mesh_motion': 'mesh',
    'mesh_phase': 'mesh',
    'mesh_stiffness': 'mesh',
    'mesh_stiffness_slope': 'mesh',
    'motion': 'motion',
    'pack': 'packed',
    'pieces': 'motion',
    'pinion_torques': 'drive',
    'rhs': 'motion',
    'rhs_vector': 'motion',
    'state_rate': 'motion',
    'static_transmission_error': 'mesh',
    'stiffest_linearization': 'motion',
}


def __getattr__(name: str) -> object:
    module = MOVED_NAMES.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    new = f'{__package__}.{module}'
    warnings.warn(f'{__name__}.{name} moved to {new}.{name}; the old path goes in the next '
                  'release', DeprecationWarning, stacklevel=2)
    return getattr(importlib.import_module(new), name)


def __dir__() -> list[str]:
    return sorted(MOVED_NAMES)
