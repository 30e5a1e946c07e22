"""The report's first page: the worked example and its results in physical units.

Every number comes from the parameters (`TableParams()`, the paper's example) or from the
results of sections 1 and 9; a one-line verdict per section is read from the sections'
own verdicts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..params.table import PAPER_DRIVE_TORQUE, PAPER_PINION_SPEED, TableParams
from ..physics.quantities import (
    equivalent_mass,
    mean_mesh_force,
    natural_frequency,
    stiffness_fluctuation,
)
from .antibacklash import AntiBacklashStudy
from .common import FAILS, HOLDS, UNCHECKABLE, VAGUE, Section, fmt, table
from .derived import MODULE, Derived
from .reversals import ARCSEC, mesh_modes

RPM = 2.0 * math.pi / 60.0
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class Summary:
    """The example's inputs and headline results, SI units unless named otherwise."""

    params: TableParams
    ratio: float                # r2/r1, the transmission ratio of each path
    reflected_inertia: float    # I2 + (I1 + I3)·(r2/r1)², kg·m² at the table
    m_e: float                  # kg
    omega_0: float              # rad/s, √(k_m/m_e): the 1-DOF (conventional) mesh mode
    mesh_modes: tuple           # rad/s, the two mesh modes of the preloaded 3-DOF table
    pinion_speed: float         # rad/s
    table_speed: float          # rad/s
    mesh_frequency: float       # rad/s, z1·ω1 at the paper's speed
    resonance_table_speed: float  # rad/s of the table at which z1·ω1 reaches ω0
    deflection: float           # m, F_m/k_m: static mesh deflection under the paper's load
    ripple: float               # m, half range of the quasi-static deflection F_m/(k_m ± k_a)
    ste_amplitude: float        # m, ε_1 implied by the paper's fa
    lost_motion: float          # rad at the table, 2b/r2: one crossing of the gap
    pitch_radius: float         # m, m·z2/2
    dead_travel: float          # rad, simulated dead travel of the conventional reversal
    separations: int            # contact losses of the conventional reversal
    impact: float               # overshoot of the conventional mesh force, units of T/r1
    table_damping: float        # N·m·s/rad, c_t that holds the paper's speed at 400 N·m
    preload_needed: float       # N·m, minimum preload for a 400 N·m reversal at the paper's speed
    preload_resolution: float   # N·m, bisection step of that number
    preload_phases: int         # reversal instants per mesh period behind that number


def compute(derived: Derived, reversal: AntiBacklashStudy) -> Summary:
    p = TableParams()
    ratio = p.radius_table / p.radius_pinion_1
    paper = int(np.argmin(np.abs(reversal.speeds - reversal.table_speed)))
    column = int(np.argmin(np.abs(reversal.torques - PAPER_DRIVE_TORQUE)))
    k, ka = p.mesh_stiffness_mean, p.mesh_stiffness_amplitude
    force = mean_mesh_force(p, PAPER_DRIVE_TORQUE)
    conventional = reversal.conventional_metrics
    return Summary(
        params=p, ratio=ratio,
        reflected_inertia=p.inertia_table + (p.inertia_pinion_1 + p.inertia_pinion_3) * ratio ** 2,
        m_e=equivalent_mass(p), omega_0=natural_frequency(p), mesh_modes=mesh_modes(p),
        pinion_speed=PAPER_PINION_SPEED, table_speed=reversal.table_speed,
        mesh_frequency=derived.omega_e,
        resonance_table_speed=natural_frequency(p) / (p.teeth_pinion_1 * ratio),
        deflection=force / k, ripple=force * ka / (k ** 2 - ka ** 2),
        ste_amplitude=derived.ste_amplitude,
        lost_motion=2.0 * p.backlash / p.radius_table,
        pitch_radius=MODULE * p.teeth_table / 2.0,
        dead_travel=conventional.dead_travel, separations=conventional.contact_losses,
        impact=conventional.overshoot_ratio, table_damping=reversal.table_damping,
        preload_needed=float(reversal.chart[paper, column]),
        preload_resolution=reversal.resolution, preload_phases=int(reversal.instants[paper]))


def _headline(section: Section) -> str:
    """One line per section: its verdict counts and the claim that matters most."""
    order = (FAILS, VAGUE, UNCHECKABLE, HOLDS)
    counts = {v: sum(1 for x in section.verdicts if x.verdict.split(' (')[0] == v)
              for v in order}
    tally = ', '.join(f'{n} {v}' for v, n in counts.items() if n)
    key = min(section.verdicts, key=lambda x: order.index(x.verdict.split(' (')[0]))
    return (f'§{section.number} {section.title}: {tally}. Key: "{key.claim}": '
            f'**{key.verdict}**, {key.recomputed}')


def render(s: Summary, sections: list[Section]) -> str:
    p = s.params
    hz = [w / TWO_PI for w in s.mesh_modes]
    example = table(('quantity', 'value', 'note'), (
        ('pinion inertia I1 = I3', f'{fmt(p.inertia_pinion_1, 4)} kg·m²', 'paper'),
        ('table inertia I2', f'{fmt(p.inertia_table, 5)} kg·m²', 'paper'),
        ('radii r1 = r3, r2', f'{p.radius_pinion_1 * 1e3:.0f} mm, {p.radius_table * 1e3:.0f} mm',
         'tip radii m(z + 2)/2, the only ones that reproduce m_e (§1)'),
        ('ratio of each path r2/r1', f'{s.ratio:.3f}',
         f'not z2/z1 = {p.teeth_table / p.teeth_pinion_1:g}: the model levers are the radii'),
        ('inertia at the table I2 + (I1 + I3)·(r2/r1)²', f'{s.reflected_inertia:.1f} kg·m²',
         'both pinions reflected'),
        ('equivalent mass of a mesh m_e', f'{s.m_e:.4f} kg', 'I1·I2/(I1·r2² + I2·r1²)'),
        ('mesh stiffness k_m ± k_a', (f'{fmt(p.mesh_stiffness_mean, 3)} ± '
         f'{fmt(p.mesh_stiffness_amplitude, 3)} N/m'), f"k_a' = {stiffness_fluctuation(p):g}"),
        ('mesh damping c', f'{p.mesh_damping:.1f} N·s/m', 'ζ = 0.05'),
        ('drive torque, pinion speed', (f'{PAPER_DRIVE_TORQUE:.0f} N·m at '
         f'{s.pinion_speed / RPM:.0f} r/min = {s.pinion_speed:.3f} rad/s'),
         f'table {s.table_speed:.4f} rad/s'),
        ('STE amplitude ε_1', f'{s.ste_amplitude * 1e3:.2f} mm', 'fa·l; implausibly large (§1)'),
        ('preload torque T_p (package default)', f'{p.preload_torque:.0f} N·m',
         'not in the paper'),
        ('backlash half gap b (conventional drive)', f'{p.backlash * 1e6:.0f} µm',
         'not in the paper'),
    ))
    results = table(('result', 'value'), (
        ('mesh resonance, 1-DOF (paper) = conventional drive: ω0 = √(k_m/m_e)',
         f'{s.omega_0:.1f} rad/s = **{s.omega_0 / TWO_PI:.1f} Hz**'),
        ('mesh resonances of the preloaded table (3-DOF, both meshes in contact)',
         ', '.join(f'{w:.0f} rad/s = **{f:.1f} Hz**'
                   for w, f in zip(s.mesh_modes, hz, strict=True))),
        ('mesh frequency at the paper\'s speed z1·ω1',
         (f'{s.mesh_frequency:.2f} rad/s = {s.mesh_frequency / TWO_PI:.2f} Hz '
         f'({s.mesh_frequency / s.omega_0:.3f}·ω0: quasi-static)')),
        ('table speed at which the mesh frequency reaches ω0',
         (f'{s.resonance_table_speed:.2f} rad/s ({s.resonance_table_speed / s.table_speed:.0f}× '
         'the paper\'s)')),
        ('static mesh deflection under 400 N·m, F_m/k_m', f'{s.deflection * 1e6:.0f} µm'),
        ('transmission-error ripple from k_a\' at the paper\'s speed (half range)',
         f'± {s.ripple * 1e6:.1f} µm'),
        ('lost motion of the conventional drive at a reversal, one gap 2b/r2',
         (f'**{s.lost_motion * 1e6:.0f} µrad = {s.lost_motion / ARCSEC:.1f}″** at the table = '
         f'{s.lost_motion * s.pitch_radius * 1e6:.0f} µm on the '
         f'{s.pitch_radius * 1e3:.0f} mm pitch circle')),
        ('the same, simulated through an abrupt 400 N·m reversal (§9)',
         (f'{s.dead_travel * 1e6:.0f} µrad = {s.dead_travel / ARCSEC:.0f}″ = '
         f'{s.dead_travel * s.pitch_radius * 1e6:.0f} µm on the pitch circle: the gap is crossed '
         f'{s.dead_travel / s.lost_motion:.1f} times ({s.separations} separations, impact '
         f'{s.impact:.1f}·T/r1)')),
        ('lost motion of the anti-backlash drive at the same reversal', '0 (no contact loss)'),
        ('**minimum preload** for a 400 N·m reversal at the paper\'s speed',
         (f'**{s.preload_needed:.0f} N·m** (worst of {s.preload_phases} reversal instants, '
         f'bisected to {s.preload_resolution:g} N·m; '
         f'{s.preload_needed / PAPER_DRIVE_TORQUE:.2f}·T), '
         f'so the default {p.preload_torque:.0f} N·m '
         f'{"holds" if p.preload_torque >= s.preload_needed else "does not hold"}')),
        ('table load that holds the paper\'s speed at 400 N·m (used in §9)',
         f'c_t = {s.table_damping:.0f} N·m·s/rad'),
    ))
    lines = '\n'.join(f'- {_headline(section)}' for section in sections if section.verdicts)
    return f"""## Summary in physical units

The paper's worked example, as the package models it (`TableParams()`):

{example}

What it gives:

{results}

Section by section (details in the table of verdicts below):

{lines}
"""


__all__ = ['Summary', 'compute', 'render']
