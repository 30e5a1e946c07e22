"""Section 8: temperature derating k_m(1 − αΔT) and preload stiffness k_p."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..params.table import PAPER_DRIVE_TORQUE, TableParams, effective_stiffness
from ..physics.quantities import equivalent_mass
from . import measures
from .batch import Coefficients
from .common import COLORS, HOLDS, VAGUE, Section, Verdict, fmt, plt, save_figure, table
from .normalized import from_table
from .steady import steady_period

ALPHA = 1e-4                              # 1/K, the paper's value for steel
TEMPERATURE_RISES = (0.0, 25.0, 50.0, 100.0)   # K
PRELOAD_STIFFNESS = (0.0, 2e6, 5e6, 1e7)        # N/m
LENGTH = 1e-6                             # l, m


@dataclass(frozen=True)
class Case:
    label: str
    k_eff: float          # N/m
    ka_rel: float         # k_a/k_eff with k_a fixed
    omega_n: float        # √(k_eff/m_e), rad/s
    mean: float           # mean mesh deflection, µm
    amplitude: float      # (max − min)/2 of the mesh deflection, µm
    thd: float


@dataclass(frozen=True)
class ThermalStudy:
    temperature: list[Case]
    preload: list[Case]
    phase: np.ndarray
    temperature_x: np.ndarray   # steady deflection over one period, µm, per ΔT
    preload_x: np.ndarray       # steady deflection over one period, µm, per k_p


def _cases(params: list[TableParams], labels: list[str]) -> tuple[list[Case], np.ndarray,
                                                                  np.ndarray]:
    c = Coefficients.stack([from_table(p.replace(mesh_phase='time'), PAPER_DRIVE_TORQUE,
                                       LENGTH) for p in params])
    sp = steady_period(c, samples=512)
    deflection = sp.x * LENGTH * 1e6   # µm
    cases = []
    for i, (p, label) in enumerate(zip(params, labels, strict=False)):
        _, amps = measures.harmonics(sp.x[:, i])
        k_eff = effective_stiffness(p)
        cases.append(Case(label, k_eff, p.mesh_stiffness_amplitude / k_eff,
                          math.sqrt(k_eff / equivalent_mass(p)),
                          float(np.mean(deflection[:, i])),
                          float(measures.half_range(deflection[:, i])), measures.thd(amps)))
    return cases, sp.phase, deflection


def compute(quick: bool = False) -> ThermalStudy:
    base = TableParams()
    thermal = [base.replace(thermal_coefficient=ALPHA, temperature_rise=dt)
               for dt in TEMPERATURE_RISES]
    preload = [base.replace(preload_stiffness=kp) for kp in PRELOAD_STIFFNESS]
    t_cases, phase, t_x = _cases(thermal, [f'ΔT = {dt:g} K' for dt in TEMPERATURE_RISES])
    p_cases, _, p_x = _cases(preload, [f'k_p = {fmt(kp, 2)} N/m' for kp in PRELOAD_STIFFNESS])
    return ThermalStudy(t_cases, p_cases, phase, t_x, p_x)


def _table(cases: list[Case], first: str) -> str:
    return table((first, 'k_eff (N/m)', "k_a/k_eff", 'ω_n = √(k_eff/m_e) (rad/s)',
                  'mean deflection (µm)', 'amplitude (µm)', 'THD'),
                 ((c.label, fmt(c.k_eff, 5), f'{c.ka_rel:.4f}', f'{c.omega_n:.1f}',
                   f'{c.mean:.2f}', f'{c.amplitude:.2f}', f'{100 * c.thd:.2f} %')
                  for c in cases))


def render(s: ThermalStudy, outdir: Path) -> Section:
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.3), sharey=True)
    for i, c in enumerate(s.temperature):
        axes[0].plot(s.phase, s.temperature_x[:, i], color=COLORS[i], lw=1.5, label=c.label)
    for i, c in enumerate(s.preload):
        axes[1].plot(s.phase, s.preload_x[:, i], color=COLORS[i], lw=1.5, label=c.label)
    axes[0].set(xlabel='phase in the mesh period t/T_mesh', ylabel='mesh deflection δ (µm)',
                title=f'Temperature rise (α = {ALPHA:g} 1/K, k_a fixed)')
    axes[1].set(xlabel='phase in the mesh period t/T_mesh',
                title='Preload stiffness k_p added to k_m')
    for ax in axes:
        ax.legend(loc='upper left')
    fig.tight_layout()
    name, link = save_figure(fig, outdir, 'fig08_thermal_preload.png',
                             'Steady mesh deflection for temperature rises and preload stiffness')
    t0, t50 = s.temperature[0], s.temperature[2]
    p0, p_last = s.preload[0], s.preload[-1]
    body = f"""
k_eff = k_m·(1 − α·ΔT) + k_p enters the normalized equation as κ = k_eff/k_m
(`normalized.from_table`), with the drive torque 400 N·m, the mesh damping c = 717.5 N·s/m
and k_a = 10^6 N/m held fixed. Steady state = the exact periodic solution at the paper's speed
(`time` mesh phase); deflection δ = l·x in µm.

Temperature, α = {ALPHA:g} 1/K (the paper's value for steel):

{_table(s.temperature, 'temperature rise')}

Preload stiffness:

{_table(s.preload, 'preload stiffness')}

{link}

A 50 K rise lowers k_eff by {100 * (1 - t50.k_eff / t0.k_eff):.1f} %, raises k_a/k_eff from
{t0.ka_rel:.4f} to {t50.ka_rel:.4f} and lowers the natural frequency by
{100 * (1 - t50.omega_n / t0.omega_n):.2f} %: the effect exists but is negligible. It increases the relative
fluctuation only because the paper keeps k_a fixed; if the fluctuation amplitude derates
with the same modulus (k_a(T) = k_a(0)(1 − αΔT), the natural assumption for one material),
k_a' does not change at all. Thermal expansion changing the backlash, which the paper also
mentions, is not in its model or in this one (b is a parameter).
A preload stiffness equal to k_m halves k_a/k_eff ({p0.ka_rel:.3f} → {p_last.ka_rel:.3f}), raises ω_n by
√2 and cuts the deflection amplitude from {p0.amplitude:.1f} to {p_last.amplitude:.1f} µm: as the
paper says, but by assumption, not as a result: the paper gives no relation between preload
force and k_p (only "proportional"), and in a mesh with a linear force law (model.md §2) the
preload torque itself does not change the stiffness.
"""
    verdicts = [
        Verdict('higher temperature lowers stiffness and raises k_a\'', 'slight reduction',
                f'50 K: k_eff −{100 * (1 - t50.k_eff / t0.k_eff):.1f} %, k_a\' {t0.ka_rel:.3f} → {t50.ka_rel:.4f}',
                HOLDS, 'negligible; and only if k_a does not derate with k_m'),
        Verdict('preload stiffness k_p reduces k_a\' and vibration', 'k_p ∝ preload',
                f'k_p = k_m: k_a\' {p0.ka_rel:.3f} → {p_last.ka_rel:.3f}, amplitude {p0.amplitude:.1f} → {p_last.amplitude:.1f} µm',
                VAGUE, 'true by construction of K_total; k_p(preload) is never given'),
    ]
    return Section(8, 'Temperature and preload stiffness', body, [name], verdicts)


__all__ = ['Case', 'ThermalStudy', 'compute', 'render']
