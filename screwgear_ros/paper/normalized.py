"""The paper's normalized single-degree-of-freedom equation (model.md §5).

    x'' + 2ζ·x' + [κ + k_a'·cos(Ωτ + ϕ_k)]·x
        = f0 + f_v·sin(Ω_v·τ) + Σ_n fa_n·n²·Ω²·sin(nΩτ + ϕ_n)

τ = ω0·t, ω0 = √(k_m/m_e), u = δ = l·x. κ = k_eff/k_m is 1 in the paper (no thermal
derating, no preload stiffness); it keeps the reduction from the 3-DOF model exact
when those are set. Everything here is dimensionless.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..numerics import rk
from ..params.declarations import (
    ParameterError,
    kernel_fields,
    parameter,
    validate,
    yaml_lines,
)
from ..params.table import TableParams, effective_stiffness
from ..physics.jit import inline_kernel, kernel
from ..physics.quantities import equivalent_mass, mean_mesh_force, natural_frequency


@dataclass(frozen=True)
class NormalizedParams:
    """Coefficients of the normalized equation; defaults = the paper's normalized case.

    Each field is the one declaration of its coefficient (:mod:`screwgear_ros.params.declarations`);
    ``kernel=True`` fields are packed, in this order, for the compiled right-hand side.
    """

    damping_ratio: float = parameter(0.05, 'ζ', '', 'damping ratio', low=0.0, kernel=True)
    stiffness_fluctuation: float = parameter(0.1, "k_a'", '', 'relative stiffness '
                                             'fluctuation k_a/k_m', kernel=True)
    frequency_ratio: float = parameter(0.043, 'Ω', '', 'mesh frequency ratio ω_e/ω0', low=0.0,
                                       kernel=True)
    mean_load: float = parameter(512.8, 'f0', '', 'mean load F_m/(k_m·l)', kernel=True)
    excitation_amplitudes: tuple[float, ...] = parameter((1538.4,), 'fa_n', '', 'STE '
                                                         'excitation harmonics ε_n/l')
    excitation_phases: tuple[float, ...] = parameter((0.0,), 'ϕ_n', 'rad', 'phases of the '
                                                     'excitation harmonics')
    load_fluctuation_amplitude: float = parameter(0.0, 'f_v', '', 'load fluctuation '
                                                  'amplitude', kernel=True)
    load_fluctuation_frequency: float = parameter(0.0, 'Ω_v', '', 'load fluctuation '
                                                  'frequency ratio ω_v/ω0', kernel=True)
    stiffness_ratio: float = parameter(1.0, 'κ', '', 'stiffness ratio k_eff/k_m', kernel=True)
    stiffness_phase: float = parameter(0.0, 'ϕ_k', 'rad', 'phase of the stiffness '
                                       'fluctuation', kernel=True)
    initial_displacement: float = parameter(0.5, 'x(0)', '', 'initial displacement')
    initial_velocity: float = parameter(0.5, "x'(0)", '', 'initial velocity')

    def __post_init__(self) -> None:
        validate(self)
        if len(self.excitation_amplitudes) != len(self.excitation_phases):
            raise ParameterError('excitation_phases', list(self.excitation_phases),
                                 'needs one phase per excitation harmonic')

    def packed(self) -> np.ndarray:
        """Scalar coefficients for the compiled right-hand side (layout ``KERNEL``)."""
        return np.array([getattr(self, name) for name in KERNEL], dtype=np.float64)

    def harmonics(self) -> tuple[np.ndarray, np.ndarray]:
        """(fa_n, ϕ_n) as float arrays."""
        return (np.array(self.excitation_amplitudes, dtype=np.float64),
                np.array(self.excitation_phases, dtype=np.float64))


# Layout of the packed coefficient array: the kernel=True fields in declaration order,
# indices looked up by name.
KERNEL = kernel_fields(NormalizedParams)
_AT = {name: index for index, name in enumerate(KERNEL)}
ZETA, KA, OMEGA, F0 = (_AT['damping_ratio'], _AT['stiffness_fluctuation'],
                       _AT['frequency_ratio'], _AT['mean_load'])
FV, OMEGA_V = _AT['load_fluctuation_amplitude'], _AT['load_fluctuation_frequency']
KAPPA, PHI_K = _AT['stiffness_ratio'], _AT['stiffness_phase']


def from_table(p: TableParams, drive_torque: float, length_scale: float = 1e-6,
               initial_displacement: float = 0.0,
               initial_velocity: float = 0.0) -> NormalizedParams:
    """The normalized coefficients of a 3-DOF parameter set (`time` mesh phase).

    drive_torque T1 in N·m gives F_m = T1/r1; length_scale l in m. The torque
    fluctuation T_v acts on pinion 1 only (the table load stays T1·r2/r1), so it
    enters δ̈ as r1·T_v/I1: f_v = m_e·r1·T_v / (I1·k_m·l), not T_v/(r1·k_m·l).
    """
    k_m = p.mesh_stiffness_mean
    w0 = natural_frequency(p)
    m_e = equivalent_mass(p)
    return NormalizedParams(
        damping_ratio=p.mesh_damping / (2.0 * m_e * w0),
        stiffness_fluctuation=p.mesh_stiffness_amplitude / k_m,
        frequency_ratio=p.mesh_frequency / w0,
        mean_load=mean_mesh_force(p, drive_torque) / (k_m * length_scale),
        excitation_amplitudes=tuple(a / length_scale for a in p.ste_amplitudes),
        excitation_phases=p.ste_phases,
        load_fluctuation_amplitude=m_e * p.radius_pinion_1 * p.torque_fluctuation_amplitude / (
            p.inertia_pinion_1 * k_m * length_scale),
        load_fluctuation_frequency=p.torque_fluctuation_frequency / w0,
        stiffness_ratio=effective_stiffness(p) / k_m,
        stiffness_phase=p.mesh_stiffness_phase,
        initial_displacement=initial_displacement, initial_velocity=initial_velocity)


@kernel
def rhs(tau: float, x: float, v: float, c: np.ndarray, fa: np.ndarray,
        phases: np.ndarray) -> tuple[float, float]:
    """(x', x'') of the normalized equation at dimensionless time τ."""
    omega = c[OMEGA]
    # f_v = 0 (every Floquet and most report runs): skip the sine, same value
    forcing = c[F0] if c[FV] == 0.0 else c[F0] + c[FV] * math.sin(c[OMEGA_V] * tau)
    for k in range(fa.shape[0]):
        n = k + 1
        forcing += fa[k] * n * n * omega * omega * math.sin(n * omega * tau + phases[k])
    stiffness = c[KAPPA] + c[KA] * math.cos(omega * tau + c[PHI_K])
    return v, forcing - 2.0 * c[ZETA] * v - stiffness * x


@inline_kernel
def slope(tau: float, y: tuple[float, float], args: tuple) -> tuple[float, float]:
    """(x', x'') at τ of the state y = (x, x'); args = (c, fa, phases): :func:`rhs`."""
    return rhs(tau, y[0], y[1], args[0], args[1], args[2])


@kernel
def integrate(x0: float, v0: float, tau0: float, dtau: float, stride: int, out: np.ndarray,
              c: np.ndarray, fa: np.ndarray, phases: np.ndarray) -> None:
    """Fixed-step RK4 (:func:`screwgear_ros.numerics.rk.step`); out[j] = (x, x') after
    (j + 1)·stride steps of dtau from τ0 (step k starts at τ0 + k·dtau exactly)."""
    y = (x0, v0)
    args = (c, fa, phases)
    step = 0
    for j in range(out.shape[0]):
        for _ in range(stride):
            y = rk.step(slope, tau0 + step * dtau, y, dtau, args)
            step += 1
        out[j, 0] = y[0]
        out[j, 1] = y[1]


def response(params: NormalizedParams, tau_end: float, dtau: float = 0.01,
             stride: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """RK4 response from τ = 0: (τ samples, states (n, 2) of x and x'), sample 0 = x(0)."""
    n = round(tau_end / (dtau * stride))
    out = np.empty((n, 2))
    fa, phases = params.harmonics()
    integrate(params.initial_displacement, params.initial_velocity, 0.0, dtau, stride, out,
              params.packed(), fa, phases)
    tau = np.arange(n + 1) * dtau * stride
    states = np.vstack([[params.initial_displacement, params.initial_velocity], out])
    return tau, states


#: The heading lines of config/paper_normalized.yaml.
PAPER_YAML_HEADER = (
    "# The paper's normalized case (shared/spec/model.md §5–6), for the 1-DOF equation",
    "#   x'' + 2ζx' + [κ + k_a'·cos(Ωτ + ϕ_k)]x = f0 + f_v·sin(Ω_v·τ) + Σ fa_n·n²·Ω²·sin(nΩτ + ϕ_n)",
    '# All values are dimensionless (τ = ω0·t, u = l·x with l = 1 µm). Generated from the',
    '# declarations in screwgear_ros/paper/normalized.py:',
    '#   python -m screwgear_ros.paper.normalized > config/paper_normalized.yaml',
)


def paper_yaml() -> str:
    """config/paper_normalized.yaml: every coefficient with its default and symbol."""
    return '\n'.join([*PAPER_YAML_HEADER, *yaml_lines(NormalizedParams, indent='')]) + '\n'


def load_yaml(path: str | Path) -> NormalizedParams:
    """Load ``config/paper_normalized.yaml`` (a mapping of the field names)."""
    with open(path, encoding='utf-8') as stream:
        document: Mapping[str, Any] = yaml.safe_load(stream) or {}
    return NormalizedParams(**document)


__all__ = [
    'KERNEL',
    'NormalizedParams',
    'from_table',
    'integrate',
    'load_yaml',
    'paper_yaml',
    'response',
    'rhs',
    'slope',
]


if __name__ == '__main__':
    print(paper_yaml(), end='')
