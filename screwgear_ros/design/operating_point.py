"""The operating point a linear model of the table is taken at: the preload equilibrium
(no torque, no load) or the steady motion under a constant drive torque, direction and
table load, the contact branch of each mesh and the piece of the drive line it puts the
table on (:mod:`screwgear_ros.design.linearize` says how the model is taken there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..params.table import Mode, TableParams, effective_stiffness
from ..physics.drive import DrivePiece, active_path, active_speed
from ..physics.mesh import ContactBranch
from ..physics.packed import pack
from ..physics.steady import rigid_torques, steady_table_speed
from ..sim.commands import load_limit
from .errors import NoSteadyState, OperatingPointRefused

_CONTACT_TEXT = {
    ContactBranch.FORWARD: 'on its forward flank',
    ContactBranch.REVERSE: 'on its reverse flank',
    ContactBranch.LINEAR: 'in contact (no backlash: one linear law at every δ)',
    ContactBranch.GAP: 'in the gap, touching the edge of a flank (no force)',
    ContactBranch.DISENGAGED: 'disengaged (conventional mode)',
}


@dataclass(frozen=True)
class OperatingPoint:
    """Where the model is linearized (module docstring)."""

    torque: float                         # N·m, commanded magnitude
    direction: int                        # ±1
    load: float                           # N·m at the table
    state: tuple[float, ...]              # θ1, θ2, θ3 (rad, mean, θ2 = 0), ω1, ω2, ω3 (rad/s)
    path: int                             # active drive path, 1 or 3
    drive_piece: DrivePiece               # the piece of the drive line that delivers
    applied: tuple[float, float]          # T1, T3 on the pinions, N·m
    mesh_force: tuple[float, float]       # mean F1, F3, N
    contact: tuple[ContactBranch, ContactBranch]
    warnings: tuple[str, ...]

    @property
    def rotating(self) -> bool:
        return self.state[4] != 0.0

    def describe(self) -> list[str]:
        """Lines saying what was assumed."""
        speed = self.state[4]
        head = (f'steady rotation, table at {speed:.6g} rad/s' if self.rotating
                else 'static equilibrium, at rest')
        lines = [f'operating point: {head}; drive torque {self.torque:g} N·m, direction '
                 f'{self.direction:+d} (path {self.path}), load {self.load:g} N·m; the drive '
                 + ('delivers the command' if self.drive_piece == DrivePiece.COMMAND
                    else 'runs on its torque–speed line (the command has no effect)')]
        for mesh, branch, force in zip((1, 3), self.contact, self.mesh_force, strict=True):
            lines.append(f'contact assumed: mesh {mesh} {_CONTACT_TEXT[ContactBranch(branch)]}'
                         + (f', mean force {force:.6g} N' if branch not in (
                             ContactBranch.DISENGAGED, ContactBranch.GAP) else ''))
        return lines


def mean_params(params: TableParams) -> TableParams:
    """The parameters with the mesh and the drive taken as their time average: no
    stiffness fluctuation, no static transmission error, no drive torque fluctuation, no
    cogging ripple."""
    return params.replace(mesh_stiffness_amplitude=0.0,
                          ste_amplitudes=tuple(0.0 for _ in params.ste_amplitudes),
                          torque_fluctuation_amplitude=0.0, cogging_amplitude=0.0)


def _number(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value):
        raise OperatingPointRefused(f'{name} must be a finite number, got {value!r}')
    return float(value)


def operating_point(params: TableParams, torque: float = 0.0, load: float = 0.0,
                    direction: int = 1) -> OperatingPoint:
    """The operating point for a constant drive torque (N·m, 0 … max_torque), direction
    (±1) and table load (N·m): module docstring. :class:`~.errors.OperatingPointRefused`
    when a value is one the node refuses, :class:`~.errors.NoSteadyState` when nothing
    makes the motion steady."""
    torque, load = _number('torque', torque), _number('load', load)
    if direction not in (1, -1):
        raise OperatingPointRefused(f'direction must be +1 or -1, got {direction!r}')
    if not 0.0 <= torque <= params.max_torque:
        raise OperatingPointRefused(f'torque must be within 0 … {params.max_torque:g} N·m '
                                  f'(max_torque), got {torque:g}')
    limit = load_limit(params.max_torque, params.radius_pinion_1, params.radius_table)
    if abs(load) > limit:
        raise OperatingPointRefused(f'|load| must be <= {limit:g} N·m, got {load:g}')
    model = pack(mean_params(params))
    p = model.p
    conventional = params.mode is Mode.CONVENTIONAL
    path = active_path(params.mode, direction)
    r1, r2, r3 = params.radius_pinion_1, params.radius_table, params.radius_pinion_3
    # the rigid steady motion, solved on the torque terms (physics.steady)
    table_speed = steady_table_speed(model, torque, load, direction)
    if not math.isfinite(table_speed):
        raise NoSteadyState(
            f'no steady state: the drive torque {torque:g} N·m against the load {load:g} N·m '
            'accelerates the table forever (nothing in the model holds it back: no '
            'drive_no_load_speed, no table_damping or other loss)')
    if table_speed == 0.0:
        table_speed = 0.0         # no negative zero in the point
    sense = math.copysign(1.0, table_speed) if table_speed != 0.0 else 0.0
    tau, terms, piece, _ = rigid_torques(model, table_speed, sense, torque, direction, load)
    w1 = table_speed * r2 / r1
    w3 = 0.0 if conventional else table_speed * r2 / r3
    speed_active = active_speed(w1, w3, float(direction), p)
    t1, t3 = terms.drive[0] + terms.cogging[0], terms.drive[2] + terms.cogging[2]
    # each pinion passes what acts on it to its mesh: Q = r·F (the mesh averaged)
    f1 = tau[0] / r1
    f3 = 0.0 if conventional else tau[2] / r3
    imbalance = r2 * (f1 + f3) + tau[1]
    scale = max(abs(load), abs(r2 * f1), abs(r2 * f3), 1.0)
    if (sense != 0.0 or not _has_friction(params)) and abs(imbalance) > 1e-9 * scale:
        raise NoSteadyState(f'no steady state found: a table torque of {imbalance:g} N·m '
                            'is left over at the rigid steady speed')
    k = effective_stiffness(params)
    gap = params.backlash
    contact, deflection = [], []
    for force, engaged, rest in ((f1, True, gap), (f3, not conventional, -gap)):
        if not engaged:
            contact.append(ContactBranch.DISENGAGED)
            deflection.append(rest)
        elif gap <= 0.0:
            contact.append(ContactBranch.LINEAR)
            deflection.append(force / k)
        elif force > 0.0:
            contact.append(ContactBranch.FORWARD)
            deflection.append(gap + force / k)
        elif force < 0.0:
            contact.append(ContactBranch.REVERSE)
            deflection.append(-gap + force / k)
        else:
            contact.append(ContactBranch.GAP)
            deflection.append(rest)
    state = (deflection[0] / r1, 0.0, deflection[1] / r3, w1, table_speed, w3)
    warnings = _static_warnings(params, contact, piece, torque, speed_active, p)
    return OperatingPoint(torque, direction, load, tuple(float(v) for v in state), path,
                          piece, (float(t1), float(t3)), (float(f1), float(f3)),
                          (contact[0], contact[1]), tuple(warnings))


def _has_friction(params: TableParams) -> bool:
    return params.table_static_torque > 0.0 or params.pinion_static_torque > 0.0


def _static_warnings(params: TableParams, contact: list[ContactBranch], piece: DrivePiece,
                     torque: float, speed: float, p: np.ndarray) -> list[str]:
    warnings = []
    for mesh, branch in zip((1, 3), contact, strict=True):
        if branch == ContactBranch.GAP:
            warnings.append(f'mesh {mesh} carries no force and touches the edge of its flank: '
                            'a push closes it, a pull opens the gap; the model (mesh open) '
                            'holds only while it stays open')
    if piece == DrivePiece.LINE:
        warnings.append('the drive runs on its torque–speed line: a change of the torque '
                        'command changes nothing (the drive_torque column of B is zero)')
    elif torque > 0.0 and params.drive_no_load_speed > 0.0:
        line = params.drive_stall_torque * (1.0 - speed / params.drive_no_load_speed)
        if abs(line - torque) <= 0.05 * torque:
            warnings.append(f'the drive sits near the corner of its torque–speed line '
                            f'({line:.4g} N·m at this speed): a faster motion puts it on the '
                            'line, a piece this model does not have')
    return warnings


__all__ = [
    'OperatingPoint',
    'mean_params',
    'operating_point',
]
