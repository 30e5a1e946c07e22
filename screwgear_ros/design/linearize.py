"""A linear model of the 3-DOF table at an operating point: ``dx/dt = A·x + B·u``,
``y = C·x + D·u`` (deviations from the point).

The operating point is the preload equilibrium (no torque, no load) or the steady motion
under a constant drive torque, direction and table load: the rigid motion at the speed
where the torque the drive delivers (its torque–speed line, docs/model_notes.md §10)
balances the load and the table damping
(:func:`~screwgear_ros.physics.quantities.terminal_speed`), at rest when nothing turns the table.
In steady rotation the mesh phase advances, so the model takes the mesh as its time average: stiffness k_eff = k_m·(1 − α·ΔT)
+ k_p (the fluctuation k_a averages out), no static transmission error (a periodic
excitation of the mesh, not a function of the deviations), lever r. Each mesh is on the
branch of the contact law its mean force puts it on, and the drive on the piece of its line
that delivers the torque at that speed.

Standing still (a static point in `angle` phase) the mesh phase does not sweep: ``mesh =
'frozen'`` linearizes the full model at its rest angle instead (the stiffness K(φ0) and the
STE's slope in the pinion's lever there), which is what the table does for small motions
while it stands.

A, B are the model's own equations of motion (:func:`~screwgear_ros.physics.model.motion`) on
those branches, evaluated with the averaged mesh: there they are affine in the state and
the inputs, so central differences give them exactly.

States: the angle of pinion 1, table, pinion 3, then their speeds (rad, rad/s; pinion
angles counted in the sense that drives the table forward, as in the model). Inputs: the
drive torque magnitude (N·m, cmd_torque: the active pinion's in the commanded direction)
and the table load (N·m, load_torque). Outputs: angle and speed of the table and of each
pinion, and the transmission error δ of the active path (m).

Why one module of this length: the operating point, the contact branch and drive piece it
puts the table on, the matrices on those branches and the modes read off them are one
derivation; each step needs the branch choices of the one before.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from enum import StrEnum
from pathlib import Path

import numpy as np

from ..params.table import MeshPhase, Mode, TableParams, effective_stiffness
from ..physics.model import (
    NEWTON_ITERATIONS,
    ContactBranch,
    Drive,
    DrivePiece,
    Pieces,
    active_path,
    active_speed,
    drive_on,
    drive_piece,
    drive_targets,
    drive_torques,
    equilibrium_state,
    mesh_motion,
    motion,
    pack,
)
from ..physics.quantities import terminal_speed
from ..sim.commands import load_limit

STATES = ('pinion_1_angle', 'table_angle', 'pinion_3_angle',
          'pinion_1_speed', 'table_speed', 'pinion_3_speed')
STATE_UNITS = ('rad', 'rad', 'rad', 'rad/s', 'rad/s', 'rad/s')
INPUTS = ('drive_torque', 'load')
INPUT_UNITS = ('N·m', 'N·m')
OUTPUTS = ('table_angle', 'table_speed', 'pinion_1_angle', 'pinion_1_speed',
           'pinion_3_angle', 'pinion_3_speed', 'transmission_error')
OUTPUT_UNITS = ('rad', 'rad/s', 'rad', 'rad/s', 'rad', 'rad/s', 'm')
#: The state each angle/speed output reads (the transmission error is built apart).
_OUTPUT_STATE = {'table_angle': 1, 'table_speed': 4, 'pinion_1_angle': 0,
                 'pinion_1_speed': 3, 'pinion_3_angle': 2, 'pinion_3_speed': 5}

#: Eigenvalues below this fraction of the largest are zero (a rigid body): a double zero
#: comes out of eig as ±√(ε·‖A‖), ε the rounding of A's entries (larger for the frozen
#: model's differences).
ZERO_EIGENVALUE = 1e-5
#: A mesh force the ripple of the mesh excitation brings within this fraction of the mean
#: force of a contact is "near a contact change".
NEAR_CONTACT_CHANGE = 0.5

_CONTACT_TEXT = {
    ContactBranch.FORWARD: 'on its forward flank',
    ContactBranch.REVERSE: 'on its reverse flank',
    ContactBranch.LINEAR: 'in contact (no backlash: one linear law at every δ)',
    ContactBranch.GAP: 'in the gap, touching the edge of a flank (no force)',
    ContactBranch.DISENGAGED: 'disengaged (conventional mode)',
}


class MeshModel(StrEnum):
    """How the linear model takes the mesh: over its period, or frozen where it stands."""

    AVERAGE = 'average'
    FROZEN = 'frozen'


class OperatingPointError(ValueError):
    """No operating point for these inputs (bad value, or no steady motion); says why."""


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
        for mesh, branch, force in zip((1, 3), self.contact, self.mesh_force):
            lines.append(f'contact assumed: mesh {mesh} {_CONTACT_TEXT[ContactBranch(branch)]}'
                         + (f', mean force {force:.6g} N' if branch not in (
                             ContactBranch.DISENGAGED, ContactBranch.GAP) else ''))
        return lines


@dataclass(frozen=True)
class ModeInfo:
    """One mode of A: an oscillating pair (shown once) or a real eigenvalue."""

    eigenvalue: complex
    frequency: float                      # natural frequency |λ|, rad/s
    damping: float                        # ζ = −Re λ / |λ| (1 for a real decaying pole)
    shape: str
    vector: tuple[complex, complex, complex]   # angle part, largest entry 1

    @property
    def hz(self) -> float:
        return self.frequency / (2.0 * math.pi)

    @property
    def oscillating(self) -> bool:
        return self.eigenvalue.imag > 0.0


@dataclass(frozen=True)
class LinearModel:
    """A, B, C, D with named states, inputs and outputs at ``point``."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    point: OperatingPoint
    params: TableParams
    mesh: MeshModel = None            # type: ignore[assignment]  # set in __post_init__
    states: tuple[str, ...] = STATES
    inputs: tuple[str, ...] = INPUTS
    outputs: tuple[str, ...] = OUTPUTS

    def __post_init__(self) -> None:
        object.__setattr__(self, 'mesh', MeshModel(self.mesh or MeshModel.AVERAGE))

    def modes(self) -> list[ModeInfo]:
        """The modes by rising frequency: the motions no spring holds (eigenvalue 0: the
        rigid body, a pinion whose mesh is open), then each oscillating pair once and each
        real eigenvalue."""
        lam, vec = np.linalg.eig(self.a)
        scale = float(np.max(np.abs(lam))) or 1.0
        found = self._free_motions()
        for k in range(len(lam)):
            value = complex(lam[k])
            # zero eigenvalues come out of eig as ±√(eps·‖A‖) (defective): taken above
            if abs(value) <= ZERO_EIGENVALUE * scale or value.imag < -1e-9 * scale:
                continue                              # a conjugate is shown once
            if abs(value.imag) <= 1e-9 * scale:
                value = complex(value.real, 0.0)
            v = vec[:3, k] if np.any(np.abs(vec[:3, k]) > 0) else vec[3:, k]
            v = v / v[np.argmax(np.abs(v))]
            found.append(ModeInfo(value, abs(value), -value.real / abs(value),
                                  self._shape(v, False), tuple(complex(x) for x in v)))
        return sorted(found, key=lambda m: (m.frequency, -m.damping))

    def _free_motions(self) -> list[ModeInfo]:
        """The zero modes: angle motions on which no spring acts (the null space of the
        stiffness block of A), a pinion that touches nothing on its own, the rest rigid."""
        stiffness = self.a[3:, :3]
        tol = ZERO_EIGENVALUE * (float(np.abs(stiffness).max()) or 1.0)
        _, sigma, vt = np.linalg.svd(stiffness)
        null = vt[sigma <= tol]
        if len(null) == 0:
            return []
        found = []
        alone = [i for i in (0, 2) if not np.any(np.abs(stiffness[:, i]) > tol)
                 and not np.any(np.abs(stiffness[i, :]) > tol)]
        for i in alone:
            v = np.zeros(3, dtype=complex)
            v[i] = 1.0
            found.append(ModeInfo(0j, 0.0, 0.0, self._shape(v, True), tuple(v)))
        for _ in range(len(null) - len(alone)):
            p = self.params
            v = np.array([p.radius_table / p.radius_pinion_1, 1.0,
                          p.radius_table / p.radius_pinion_3], dtype=complex)
            for i in alone:
                v[i] = 0.0
            v = v / v[np.argmax(np.abs(v))]
            found.append(ModeInfo(0j, 0.0, 0.0, 'rigid body', tuple(v)))
        return found

    def _shape(self, v: np.ndarray, zero: bool) -> str:
        """A one-line description of an angle mode shape ``v`` (largest entry 1)."""
        p = self.params
        moves = np.real(v) * (p.radius_pinion_1, p.radius_table, p.radius_pinion_3)
        size = float(np.max(np.abs(moves)))
        engaged = [0, 2] if p.mode is Mode.ANTI_BACKLASH else [0]
        in_contact = [i for i, branch in zip((0, 2), self.point.contact)
                      if branch not in (ContactBranch.GAP, ContactBranch.DISENGAGED)]
        still = [abs(moves[i] - moves[1]) <= 1e-3 * size for i in in_contact]
        if p.mode is Mode.CONVENTIONAL and abs(moves[2]) > 0.999 * size \
                and abs(moves[0]) + abs(moves[1]) <= 1e-6 * size:
            return 'pinion 3 alone (disengaged)'
        if all(still):
            free = [i for i in engaged if i not in in_contact and abs(moves[i]) > 1e-6 * size]
            if free and all(abs(moves[i]) <= 1e-3 * size for i in in_contact + [1]):
                return 'pinion {} alone (its mesh is open)'.format(' and '.join(
                    '1' if i == 0 else '3' for i in free))
            return 'rigid body' if zero else 'rigid body (damped: table bearing, drive line)'
        if len(in_contact) == 2:
            if moves[0] * moves[2] < 0.0:
                return 'pinions against each other (table nearly still)'
            return 'pinions against the table'
        pinion = '1' if in_contact and in_contact[0] == 0 else '3'
        return f'pinion {pinion} against the table'

    def response(self, frequency_hz: np.ndarray) -> np.ndarray:
        """Frequency response C·(jωI − A)⁻¹·B + D, shape (outputs, inputs, frequencies)."""
        f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        eye = np.eye(self.a.shape[0])
        out = np.empty((self.c.shape[0], self.b.shape[1], len(f)), dtype=complex)
        for k, hz in enumerate(f):
            out[:, :, k] = self.c @ np.linalg.solve(2j * math.pi * hz * eye - self.a, self.b) \
                + self.d
        return out

    def poles(self) -> np.ndarray:
        return np.linalg.eigvals(self.a)

    def arrays(self) -> dict[str, np.ndarray]:
        """What :meth:`save` writes: plain arrays, loadable without pickle."""
        pt = self.point
        modes = [m for m in self.modes()]
        return {
            'A': self.a, 'B': self.b, 'C': self.c, 'D': self.d,
            'states': np.array(self.states), 'inputs': np.array(self.inputs),
            'outputs': np.array(self.outputs),
            'state_units': np.array(STATE_UNITS), 'input_units': np.array(INPUT_UNITS),
            'output_units': np.array(OUTPUT_UNITS),
            'x0': np.array(pt.state), 'u0': np.array([pt.torque, pt.load]),
            'direction': np.array(pt.direction), 'mesh': np.array(self.mesh.value),
            'contact': np.array([ContactBranch(b).name.lower() for b in pt.contact]),
            'mesh_force': np.array(pt.mesh_force),
            'mode_frequency_rad_s': np.array([m.frequency for m in modes]),
            'mode_damping_ratio': np.array([m.damping for m in modes]),
            'mode_shape': np.array([m.shape for m in modes]),
            'parameters': np.array(json.dumps(self.params.as_dict())),
        }

    def save(self, path: str | Path) -> None:
        """The model as .npz (default), or as a MATLAB .mat file when ``path`` ends in .mat."""
        path = Path(path)
        data = self.arrays()
        if path.suffix == '.mat':
            from scipy.io import savemat
            # names as cell arrays of strings (a char matrix would pad them with blanks)
            savemat(path, {k: (np.array(list(v), dtype=object) if v.dtype.kind == 'U'
                               and v.ndim else v) for k, v in data.items()}, oned_as='column')
            return
        with open(path, 'wb') as stream:       # np.savez would add .npz to another suffix
            np.savez(stream, **data)

    def control_pickle(self) -> bytes:
        """The model as a pickled ``control.StateSpace``. python-control's own objects do not
        pickle (they hold a lambda), so the pickle rebuilds one with ``control.ss`` and the
        names: loading it needs python-control, not this package."""
        import copyreg
        import functools
        import io
        import pickle

        import control
        system = self.to_control()
        build = functools.partial(control.ss, states=list(self.states), inputs=list(self.inputs),
                                  outputs=list(self.outputs), name='screwgear_table')
        stream = io.BytesIO()
        pickler = pickle.Pickler(stream)
        pickler.dispatch_table = copyreg.dispatch_table.copy()
        pickler.dispatch_table[type(system)] = lambda s: (build, (s.A, s.B, s.C, s.D))
        pickler.dump(system)
        return stream.getvalue()

    def to_control(self):
        """The model as a ``control.StateSpace`` (python-control; ImportError without it)."""
        import control
        return control.ss(self.a, self.b, self.c, self.d, states=list(self.states),
                          inputs=list(self.inputs), outputs=list(self.outputs),
                          name='screwgear_table')


def mean_params(params: TableParams) -> TableParams:
    """The parameters with the mesh taken as its time average: no stiffness fluctuation,
    no static transmission error, no drive torque fluctuation."""
    return params.replace(mesh_stiffness_amplitude=0.0,
                          ste_amplitudes=tuple(0.0 for _ in params.ste_amplitudes),
                          torque_fluctuation_amplitude=0.0)


def _number(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value):
        raise OperatingPointError(f'{name} must be a finite number, got {value!r}')
    return float(value)


def operating_point(params: TableParams, torque: float = 0.0, load: float = 0.0,
                    direction: int = 1) -> OperatingPoint:
    """The operating point for a constant drive torque (N·m, 0 … max_torque), direction
    (±1) and table load (N·m): module docstring. :class:`OperatingPointError` when a value
    is one the node refuses or when nothing makes the motion steady."""
    torque, load = _number('torque', torque), _number('load', load)
    if direction not in (1, -1):
        raise OperatingPointError(f'direction must be +1 or -1, got {direction!r}')
    if not 0.0 <= torque <= params.max_torque:
        raise OperatingPointError(f'torque must be within 0 … {params.max_torque:g} N·m '
                                  f'(max_torque), got {torque:g}')
    limit = load_limit(params.max_torque, params.radius_pinion_1, params.radius_table)
    if abs(load) > limit:
        raise OperatingPointError(f'|load| must be <= {limit:g} N·m, got {load:g}')
    mean = mean_params(params)
    model = pack(mean)
    p = model.p
    conventional = params.mode is Mode.CONVENTIONAL
    path = active_path(params.mode, direction)
    r1, r2, r3 = params.radius_pinion_1, params.radius_table, params.radius_pinion_3
    r_active = r1 if path == 1 else r3
    # table speed of the rigid steady motion
    if torque == 0.0:             # the drive is off: only the load and the bearing act
        if load == 0.0:
            table_speed = 0.0
        elif params.table_damping > 0.0:
            table_speed = -load / params.table_damping
        else:
            raise OperatingPointError(
                f'no steady state: the load {load:g} N·m accelerates the table forever '
                '(no drive torque against it, table_damping 0)')
    else:
        driving = params.replace(radius_pinion_1=r_active) if r_active != r1 else params
        held = abs(direction * load * r_active / r2 - torque) <= 1e-12 * torque
        if held and min(torque, params.drive_stall_torque) == torque:
            speed = 0.0           # the load holds the drive torque exactly: at rest
        else:
            speed = terminal_speed(driving, torque, direction * load)
        if not math.isfinite(speed):
            raise OperatingPointError(
                f'no steady state: the drive torque {torque:g} N·m accelerates the table '
                'forever (ideal torque source, drive_no_load_speed 0, table_damping 0, and '
                f'a load other than {direction * torque * r2 / r_active:g} N·m to hold it)')
        table_speed = direction * speed * r_active / r2
    if table_speed == 0.0:
        table_speed = 0.0         # no negative zero in the point
    w1 = table_speed * r2 / r1
    w3 = 0.0 if conventional else table_speed * r2 / r3
    speed_active = active_speed(w1, w3, float(direction), p)
    piece = DrivePiece(drive_piece(torque, speed_active, p))
    t1, t3 = drive_torques(0.0, drive_on(piece, torque, speed_active, p), float(direction), p)
    f1 = t1 / r1
    f3 = 0.0 if conventional else t3 / r3
    imbalance = r2 * (f1 + f3) - load - params.table_damping * table_speed
    if abs(imbalance) > 1e-9 * max(abs(load), abs(r2 * f1), 1.0):
        raise OperatingPointError(f'no steady state found: a table torque of {imbalance:g} N·m '
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


def _static_warnings(params: TableParams, contact: list[ContactBranch], piece: DrivePiece,
                     torque: float, speed: float, p: np.ndarray) -> list[str]:
    warnings = []
    for mesh, branch in zip((1, 3), contact):
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


def _derivative(x: np.ndarray, u: np.ndarray, point: OperatingPoint, model) -> np.ndarray:
    # The drives' current loops held at their targets: the linear model takes the drive
    # torque as instant (its lag is a first-order filter in series with it).
    lag1, lag3 = drive_targets(point.drive_piece, x[3], x[5], u[0], float(point.direction),
                               model.p)
    accelerations = motion(0.0, (x[0], x[1], x[2], x[3], x[4], x[5], lag1, lag3), model,
                           Drive(u[0], float(point.direction), u[1]),
                           Pieces(point.contact[0], point.contact[1], point.drive_piece))[:3]
    return np.concatenate([x[3:], accelerations])


def _differences(point: OperatingPoint, model, x0: np.ndarray, dx: np.ndarray,
                 du: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A and B by central differences of the equations of motion on the point's branches,
    steps ``dx`` in the state and ``du`` in the inputs."""
    u0 = np.array([point.torque, point.load])
    a = np.empty((6, 6))
    for j in range(6):
        e = np.zeros(6)
        e[j] = dx[j]
        a[:, j] = (_derivative(x0 + e, u0, point, model)
                   - _derivative(x0 - e, u0, point, model)) / (2.0 * dx[j])
    b = np.empty((6, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = du[j]
        b[:, j] = (_derivative(x0, u0 + e, point, model)
                   - _derivative(x0, u0 - e, point, model)) / (2.0 * du[j])
    return a, b


#: Central-difference steps of the frozen model: angles, speeds (rad, rad/s), inputs (N·m).
FROZEN_STEPS = (1e-9, 1e-6, 1e-3)


def _frozen(params: TableParams, point: OperatingPoint) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """The rest state of the full model under the point's inputs (from the preload
    equilibrium, Newton's method on the angles with least-norm steps: the rigid body leaves
    one angle free) and A, B there by central differences, on the point's branches."""
    model = pack(params)
    x = np.array(equilibrium_state(params), dtype=float)
    u = np.array([point.torque, point.load])
    angle, speed, inputs = FROZEN_STEPS
    dx = np.array([angle] * 3 + [speed] * 3)
    for _ in range(NEWTON_ITERATIONS):
        a, _ = _differences(point, model, x, dx, np.full(2, inputs))
        residual = _derivative(x, u, point, model)[3:]
        step = np.linalg.lstsq(a[3:, :3], -residual, rcond=None)[0]
        x[:3] += step
        if np.max(np.abs(step)) <= 1e-15 * max(1.0, float(np.max(np.abs(x[:3])))):
            break
    else:
        raise OperatingPointError('no rest state of the full model found under these inputs '
                                  '(Newton did not converge)')
    a, b = _differences(point, model, x, dx, np.full(2, inputs))
    return a, b, x


def linearize(params: TableParams, torque: float = 0.0, load: float = 0.0,
              direction: int = 1, mesh: MeshModel | str = 'average') -> LinearModel:
    """The linear model at :func:`operating_point` (module docstring). ``mesh``: `average`
    (the mesh over its period, module docstring) or `frozen`: at a static point in `angle`
    phase, the full model at its rest angle (the stiffness K(φ0), the STE's slope in the
    pinion's lever), what the table does for small motions while it stands."""
    mesh = MeshModel(mesh)
    point = operating_point(params, torque, load, direction)
    if mesh is MeshModel.FROZEN:
        if point.rotating:
            raise OperatingPointError('a frozen mesh needs a static operating point: in steady '
                                      'rotation the mesh phase advances (use the average)')
        if params.mesh_phase is not MeshPhase.ANGLE:
            raise OperatingPointError('a frozen mesh needs the angle mesh phase: in time phase '
                                      'the mesh phase advances at rest too (use the average)')
        a, b, state = _frozen(params, point)
        point = replace(point, state=tuple(float(v) for v in state))
    else:
        # affine in x and u on fixed branches: unit central differences are exact
        a, b = _differences(point, pack(mean_params(params)), np.array(point.state),
                            np.ones(6), np.ones(2))
    c = np.zeros((len(OUTPUTS), 6))
    for i, name in enumerate(OUTPUTS):
        if name == 'transmission_error':
            pinion = 0 if point.path == 1 else 2
            radius = params.radius_pinion_1 if pinion == 0 else params.radius_pinion_3
            if mesh is MeshModel.FROZEN:      # δ = r·θ − ε(z·θ) − r2·θ2: the STE's slope
                teeth = params.teeth_pinion_1 if pinion == 0 else params.teeth_pinion_3
                packed = pack(params)
                slope = mesh_motion(point.state[pinion], 0.0, radius, teeth, point.state[1],
                                    0.0, 0.0, packed)[1]
                radius -= teeth * slope
            c[i, pinion] = radius
            c[i, 1] = -params.radius_table
        else:
            c[i, _OUTPUT_STATE[name]] = 1.0
    d = np.zeros((len(OUTPUTS), 2))
    linear = LinearModel(a, b, c, d, point, params, mesh)
    ripple = _ripple_warnings(linear)
    if ripple:
        point = replace(point, warnings=point.warnings + tuple(ripple))
        linear = LinearModel(a, b, c, d, point, params, mesh)
    return linear


def _ripple_warnings(linear: LinearModel) -> list[str]:
    """Meshes whose mean force the mesh excitation may bring to a contact change.

    The static transmission error drives each mesh as a displacement ε(φ) in δ at the mesh
    frequency and its harmonics (z·|ω| in `angle` phase, ω_e in `time` phase); the force
    it makes there follows from this linear model: F = (k + j·ω·c)·(δ_bodies − ε), the bodies
    driven by the same mesh. The stiffness fluctuation adds k_a·|f| on the mean deflection f.
    Their sum is compared with the mean force of each flank contact.
    """
    params, point = linear.params, linear.point
    if params.backlash <= 0.0:
        return []                   # no flank to lift off: one law at every δ
    omega_mesh = (params.mesh_frequency if params.mesh_phase.value == 'time'
                  else None)
    warnings = []
    k, c = effective_stiffness(params), params.mesh_damping
    inertia = np.array([params.inertia_pinion_1, params.inertia_table, params.inertia_pinion_3])
    for mesh, branch, force in zip((1, 3), point.contact, point.mesh_force):
        if branch not in (ContactBranch.FORWARD, ContactBranch.REVERSE):
            continue
        radius = params.radius_pinion_1 if mesh == 1 else params.radius_pinion_3
        teeth = params.teeth_pinion_1 if mesh == 1 else params.teeth_pinion_3
        speed = abs(point.state[3 if mesh == 1 else 5])
        base = omega_mesh if omega_mesh is not None else teeth * speed
        g = np.zeros(3)
        g[0 if mesh == 1 else 2], g[1] = radius, -params.radius_table
        ripple = params.mesh_stiffness_amplitude * abs(force) / k
        if base > 0.0:
            for n, amplitude in enumerate(params.ste_amplitudes, start=1):
                w = n * base
                z = k + 1j * w * c
                column = np.concatenate([np.zeros(3), g * z / inertia])   # ε in δ: force −z·ε, on the bodies −g·F
                x = np.linalg.solve(1j * w * np.eye(6) - linear.a, column)
                ripple += abs(z * (g @ x[:3] - 1.0)) * abs(amplitude)
        if ripple >= NEAR_CONTACT_CHANGE * abs(force):
            warnings.append(
                f'near a contact change: the mesh excitation (STE, stiffness fluctuation) '
                f'moves the force of mesh {mesh} by up to about {ripple:.4g} N around its mean '
                f'{force:.4g} N; where it reaches zero the flank lifts and the linear model '
                'does not hold')
    return warnings


__all__ = [
    'FROZEN_STEPS',
    'INPUTS',
    'INPUT_UNITS',
    'NEAR_CONTACT_CHANGE',
    'OUTPUTS',
    'OUTPUT_UNITS',
    'STATES',
    'STATE_UNITS',
    'LinearModel',
    'MeshModel',
    'ModeInfo',
    'OperatingPoint',
    'OperatingPointError',
    'linearize',
    'mean_params',
    'operating_point',
]
