"""The linear model of the table at an operating point, ``dx/dt = A·x + B·u``,
``y = C·x + D·u`` with named states, inputs and outputs (:class:`LinearModel`): its modes,
frequency response and the files it saves to. :func:`~screwgear_ros.design.linearize.linearize`
builds it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from ..params.table import Mode, TableParams
from ..physics.mesh import ContactBranch
from .operating_point import OperatingPoint

STATES = ('pinion_1_angle', 'table_angle', 'pinion_3_angle',
          'pinion_1_speed', 'table_speed', 'pinion_3_speed')
STATE_UNITS = ('rad', 'rad', 'rad', 'rad/s', 'rad/s', 'rad/s')
#: The state a drive lag adds (:mod:`.loop_dynamics`): the torque the drive delivers.
LAG_STATE, LAG_UNIT = 'drive_torque_delivered', 'N·m'
INPUTS = ('drive_torque', 'load')
INPUT_UNITS = ('N·m', 'N·m')
OUTPUTS = ('table_angle', 'table_speed', 'pinion_1_angle', 'pinion_1_speed',
           'pinion_3_angle', 'pinion_3_speed', 'transmission_error')
OUTPUT_UNITS = ('rad', 'rad/s', 'rad', 'rad/s', 'rad', 'rad/s', 'm')

#: Eigenvalues below this fraction of the largest are zero (a rigid body): a double zero
#: comes out of eig as ±√(ε·‖A‖), ε the rounding of A's entries (larger for the frozen
#: model's differences).
ZERO_EIGENVALUE = 1e-5


class MeshModel(StrEnum):
    """How the linear model takes the mesh: over its period, or frozen where it stands."""

    AVERAGE = 'average'
    FROZEN = 'frozen'


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
    #: The joint sensors as a sampled-data loop sees them (:mod:`.loop_dynamics`), or None
    #: (outputs as the exact state).
    sensors: Any = None
    #: What sensor and drive dynamics the model holds, one line each.
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, 'mesh', MeshModel(self.mesh or MeshModel.AVERAGE))

    @property
    def state_units(self) -> tuple[str, ...]:
        return STATE_UNITS + ((LAG_UNIT,) if LAG_STATE in self.states else ())

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
            v = vec[:3, k] if np.any(np.abs(vec[:3, k]) > 0) else vec[3:6, k]
            v = v / v[np.argmax(np.abs(v))]
            lag = LAG_STATE in self.states and abs(value - self.a[-1, -1]) <= 1e-9 * scale
            found.append(ModeInfo(value, abs(value), -value.real / abs(value),
                                  'the drive\'s current loop (its lag)' if lag
                                  else self._shape(v, False),
                                  (complex(v[0]), complex(v[1]), complex(v[2]))))
        return sorted(found, key=lambda m: (m.frequency, -m.damping))

    def _free_motions(self) -> list[ModeInfo]:
        """The zero modes: angle motions on which no spring acts (the null space of the
        stiffness block of A), a pinion that touches nothing on its own, the rest rigid."""
        stiffness = self.a[3:6, :3]
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
        in_contact = [i for i, branch in zip((0, 2), self.point.contact, strict=True)
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
            'state_units': np.array(self.state_units), 'input_units': np.array(INPUT_UNITS),
            'output_units': np.array(OUTPUT_UNITS),
            'x0': np.array(pt.state), 'u0': np.array([pt.torque, pt.load]),
            'direction': np.array(pt.direction), 'mesh': np.array(self.mesh.value),
            'contact': np.array([ContactBranch(b).name.lower() for b in pt.contact]),
            'mesh_force': np.array(pt.mesh_force),
            'mode_frequency_rad_s': np.array([m.frequency for m in modes]),
            'mode_damping_ratio': np.array([m.damping for m in modes]),
            'mode_shape': np.array([m.shape for m in modes]),
            'parameters': np.array(json.dumps(self.params.as_dict())),
            **self._dynamics_arrays(),
        }

    def _dynamics_arrays(self) -> dict[str, np.ndarray]:
        """The sensors (per joint: pinion 1, table, pinion 3) and the notes on the
        dynamics the model holds, when it holds any (:mod:`.loop_dynamics`)."""
        out: dict[str, np.ndarray] = {}
        if self.notes:
            out['dynamics'] = np.array(self.notes)
        if self.sensors is not None:
            joints = self.sensors.joints
            out['sensor_delay_ticks'] = np.array([j.delay for j in joints])
            out['sensor_speed_cutoff_hz'] = np.array([j.cutoff for j in joints])
            out['sensor_speed_differenced'] = np.array([j.differenced for j in joints])
        return out

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
            # numpy's stub reads a ** mapping as also feeding its allow_pickle: bool
            np.savez(stream, **data)  # type: ignore[arg-type]

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


__all__ = [
    'INPUTS',
    'INPUT_UNITS',
    'OUTPUTS',
    'OUTPUT_UNITS',
    'STATES',
    'STATE_UNITS',
    'ZERO_EIGENVALUE',
    'LinearModel',
    'MeshModel',
    'ModeInfo',
]
