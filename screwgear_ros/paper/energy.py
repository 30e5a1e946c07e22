"""Section 11: the energy balance of the mesh, paper's equations against energy-consistent.

Beyond the paper: its equations load each pinion with the mesh force through the radius r.
With K(t) and ε(t) prescribed in time (the paper's reading) the mesh is an external
excitation and the energy balance closes once the excitation's work is counted. With the
mesh phase following the pinion (φ = z·θ, the node's default) the same equations do work
of their own; the `energy_consistent` formulation (forces from the potential ½·K(φ)·f(δ)²)
does not. The audit is :mod:`screwgear_ros.sim.energy` over runs driven through a Session:
the gear coasting at the paper's speed with no drive, load or table damping, preload,
backlash, STE, k_a and mesh damping on.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..params.table import PAPER_PINION_SPEED, MeshFormulation, TableParams
from ..physics.equilibrium import equilibrium_state
from ..sim import energy
from .common import COLORS, FAILS, HOLDS, Section, Verdict, fmt, plt, save_figure, table
from .reversals import paper_table_speed

FORMULATIONS = ('paper', 'energy_consistent')


def coasting(form: str, dt: float, duration: float, **changes) -> energy.EnergyAudit:
    """The free run: rest state under the preload, every body turning at the paper's speed
    (24 r/min at the pinions), nothing driving or braking but the mesh damping."""
    p = TableParams(mesh_formulation=MeshFormulation(form), **changes)
    y = equilibrium_state(p)
    y[3:] = (PAPER_PINION_SPEED, paper_table_speed(p), PAPER_PINION_SPEED)
    return energy.run(p, dt, duration, initial_state=y)


@dataclass(frozen=True)
class EnergyStudy:
    duration: float                     # s
    dts: tuple[float, ...]              # s, the dt sweep
    runs: dict                          # formulation → EnergyAudit at the finest dt
    relative: dict                      # formulation → max |residual| / scale, per dt
    time_phase: dict                    # formulation → relative residual, `time` phase
    miss: float                         # J, max |residual| of the paper's mesh (finest dt)
    swing_without_ste: float            # J, peak-to-peak residual of the paper mesh, ε = 0


def compute(quick: bool = False) -> EnergyStudy:
    duration = 0.5 if quick else 3.0
    dts = (80e-6, 40e-6) if quick else (80e-6, 40e-6, 20e-6)
    relative: dict[str, list[float]] = {form: [] for form in FORMULATIONS}
    runs = {}
    jobs = [(form, dt) for form in FORMULATIONS for dt in dts]
    for form, dt in tqdm(jobs, desc='energy audits', leave=False):
        audit = coasting(form, dt, duration)
        relative[form].append(audit.relative_residual)
        runs[form] = audit                       # the finest dt comes last
    time_phase = {form: coasting(form, dts[-1], duration, mesh_phase='time').relative_residual
                  for form in FORMULATIONS}
    plain = coasting('paper', dts[-1], duration, ste_amplitudes=(), ste_phases=())
    return EnergyStudy(duration, dts, runs, {k: np.array(v) for k, v in relative.items()},
                       time_phase, float(np.max(np.abs(runs['paper'].residual))),
                       float(np.ptp(plain.residual)))


def _figure(s: EnergyStudy, outdir: Path) -> tuple[str, str]:
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6), gridspec_kw={'width_ratios': [1.6, 1]})
    labels = {'paper': "paper's equations (lever r)",
              'energy_consistent': 'energy-consistent (lever r − z·ε\', + ½·z·K\'·f²)'}
    for i, form in enumerate(FORMULATIONS):
        a = s.runs[form]
        axes[0].semilogy(a.time, np.maximum(np.abs(a.residual) / a.scale, 1e-16),
                         color=COLORS[i], lw=0.8, label=labels[form])
        axes[1].loglog(np.array(s.dts) * 1e6, s.relative[form], 'o-', color=COLORS[i],
                       label=labels[form])
    finest = s.relative['energy_consistent'][-1]
    slope = finest * (np.array(s.dts) / s.dts[-1]) ** 4
    axes[1].loglog(np.array(s.dts) * 1e6, slope, ':', color='grey', label='∝ dt⁴')
    axes[0].axhline(1e-6, color='black', ls='--', lw=1, label='1e-6 (the goal)')
    axes[0].set(xlabel='time (s)', ylabel='|energy residual| / largest energy term',
                title=f'Free coasting at the paper\'s speed, dt = {s.dts[-1] * 1e6:g} µs',
                ylim=(1e-14, 10))
    axes[1].set(xlabel='integration step dt (µs)', ylabel='max |residual| / largest term',
                title='The residual against dt')
    axes[1].set_xticks(np.array(s.dts) * 1e6, [f'{dt * 1e6:g}' for dt in s.dts])
    axes[1].minorticks_off()
    axes[0].legend(loc='center right')
    axes[1].legend(loc='center left', fontsize=8)
    fig.tight_layout()
    return save_figure(fig, outdir, 'fig11_energy.png',
                       'Energy residual over time and against the step, both formulations')


def render(s: EnergyStudy, outdir: Path) -> Section:
    name, link = _figure(s, outdir)
    paper, consistent = s.runs['paper'], s.runs['energy_consistent']
    orders = np.log2(s.relative['energy_consistent'][:-1] / s.relative['energy_consistent'][1:])
    rows = [(f'{dt * 1e6:g} µs', fmt(s.relative['paper'][k], 3),
             fmt(s.relative['energy_consistent'][k], 3)) for k, dt in enumerate(s.dts)]
    tab = table(('step dt', "paper's equations", 'energy-consistent'), rows)
    body = f"""
The paper writes the equations of motion with the mesh force F = K·f(δ) + c·δ̇ acting on each
pinion through its radius r, and K(t), ε(t) given as functions of time. Read that way the mesh
is an external excitation, and the energy balance closes once its work
∫(½·K'·f² − F·ε')·φ̇ dt is counted (`time` phase, both formulations: max residual
{fmt(s.time_phase['paper'], 2)} and {fmt(s.time_phase['energy_consistent'], 2)} of the largest
term). A simulator of a table that stops and reverses needs the mesh phase to follow the
pinion (φ = z·θ): K and ε are then properties of where the teeth are. The same equations
then do work of their own: the lever should be ∂δ/∂θ = r − z·ε'(φ), and the stiffness
variation adds ½·z·K'(φ)·f², as the Lagrangian of the potential ½·K(φ)·f(δ)² gives
(derivation: docs/model_notes.md §9). `mesh_formulation: energy_consistent` uses those forces.

The audit (`screwgear_ros.sim.energy`): kinetic energy + mesh potential against the work of
drive, preload, load and the dissipation of mesh and table damping, from the state at every
integration step of a run driven through the node's Session, integrals by a 6-point rule
(O(dt⁶)). Free coasting at the paper's speed (24 r/min at the pinions, no drive, load or table
damping; default preload, backlash, ε_1 = 1.54 mm, k_a' = 0.1, ζ = 0.05) for
{s.duration:g} s, the largest energy term {fmt(consistent.scale, 3)} J:

{tab}

{link}

With the paper's equations the balance misses by up to {fmt(s.miss, 3)} J (against
{fmt(paper.scale, 3)} J stored): within milliseconds the mesh puts that much into the
coasting gear and swings it with the tooth period, the same at every step. It is not an
integration error but the equations' own work, equal to ∫(½·K'·f² − F·ε')·z·ω dt to
integration accuracy. Without the STE (k_a alone) it still swings the energy by
{fmt(s.swing_without_ste, 3)} J. The energy-consistent residual is RK4's own error: it shrinks
by 2^{'/2^'.join(f'{o:.2f}' for o in orders)} per halving of dt (RK4 is fourth order).
"""
    verdicts = [
        Verdict('the time-varying mesh (K(t), ε(t)) as an excitation of the gear',
                'equations of motion with K(t) and ε(t)',
                f'energy balance closes to {fmt(s.time_phase["paper"], 2)} with the '
                'excitation\'s work counted', HOLDS, 'as an excitation model'),
        Verdict('the same equations with the mesh phase following the pinion (φ = z·θ)',
                'not considered (K and ε are given in time)',
                f'misses the energy balance by {fmt(s.miss, 3)} J in free coasting '
                f'({100 * s.relative["paper"][-1]:.0f} % of the largest term), at every dt',
                FAILS, 'the lever must be r − z·ε\', plus ½·z·K\'·f²: energy-consistent '
                f'closes to {fmt(s.relative["energy_consistent"][-1], 2)}'),
    ]
    return Section(11, 'Energy balance of the mesh (beyond the paper)', body, [name], verdicts)


__all__ = ['FORMULATIONS', 'EnergyStudy', 'coasting', 'compute', 'render']
