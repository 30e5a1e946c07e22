"""Section 1: the derived quantities of the paper's worked example (model.md §6)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..params.table import PAPER_DRIVE_TORQUE, PAPER_PINION_SPEED, TableParams
from ..physics.quantities import (
    equivalent_mass,
    mean_mesh_force,
    mesh_frequency_at,
    natural_frequency,
)
from .common import HOLDS, VAGUE, Section, Verdict, fmt, table
from .normalized import from_table

#: The paper's printed numbers.
PAPER = {'m_e': 5.150, 'F_m': 5128.0, 'omega_0': 1393.466, 'omega_e': 60.319,
         'Omega': 0.043, 'f0': 512.8, 'fa': 1538.4, 'zeta': 0.05, 'ka': 0.1}
MODULE = 6e-3          # m
PRESSURE_ANGLE = math.radians(20.0)
PINION_MASS = 10.70    # M1, kg
LENGTH_SCALE = 1e-6    # l, m (implied by f0)


@dataclass(frozen=True)
class Derived:
    """Recomputed quantities, SI units."""

    m_e: float                 # kg, tip radii (the project's defaults)
    m_e_by_radius: dict        # radius convention → (r1, r2, m_e)
    F_m: float                 # N
    omega_0: float             # rad/s, k_m = 1e7 N/m and m_e unrounded
    omega_0_rounded: float     # rad/s, k_m = 1e7 N/m and the paper's rounded m_e = 5.150
    k_m_implied: float         # N/m, ω0² · m_e of the paper's printed numbers
    omega_e: float             # rad/s
    Omega: float               # ω_e/ω0
    f0: float                  # F_m/(k_m·l)
    length_scale: float        # l, m, implied by the paper's f0
    ste_amplitude: float       # ε_1 = fa·l, m
    zeta: float
    ka: float
    pinion_inertia_disc: float  # M1·r1²/2 with the tip radius, kg·m²
    ste_forcing: float         # m_e·ε_1·ω_e², N: the STE's inertial force amplitude


def compute(quick: bool = False) -> Derived:
    p = TableParams()
    r = {
        'pitch m·z/2': (MODULE * p.teeth_pinion_1 / 2, MODULE * p.teeth_table / 2),
        'base m·z·cos20°/2': (MODULE * p.teeth_pinion_1 * math.cos(PRESSURE_ANGLE) / 2,
                              MODULE * p.teeth_table * math.cos(PRESSURE_ANGLE) / 2),
        'tip m·(z+2)/2': (MODULE * (p.teeth_pinion_1 + 2) / 2,
                          MODULE * (p.teeth_table + 2) / 2),
    }
    by_radius = {name: (r1, r2, equivalent_mass(p.replace(radius_pinion_1=r1,
                                                           radius_table=r2,
                                                           radius_pinion_3=r1)))
                 for name, (r1, r2) in r.items()}
    w0 = natural_frequency(p)
    omega_e = mesh_frequency_at(p, PAPER_PINION_SPEED)
    f_m = mean_mesh_force(p, PAPER_DRIVE_TORQUE)
    k_m = PAPER['omega_0'] ** 2 * PAPER['m_e']
    length = f_m / (k_m * PAPER['f0'])
    normalized = from_table(p, PAPER_DRIVE_TORQUE, LENGTH_SCALE)
    m_e = equivalent_mass(p)
    eps = PAPER['fa'] * length
    return Derived(
        m_e=m_e, m_e_by_radius=by_radius, F_m=f_m, omega_0=w0,
        omega_0_rounded=math.sqrt(p.mesh_stiffness_mean / PAPER['m_e']),
        k_m_implied=k_m, omega_e=omega_e, Omega=omega_e / w0,
        f0=normalized.mean_load, length_scale=length, ste_amplitude=eps,
        zeta=normalized.damping_ratio, ka=normalized.stiffness_fluctuation,
        pinion_inertia_disc=PINION_MASS * p.radius_pinion_1 ** 2 / 2,
        ste_forcing=m_e * eps * omega_e ** 2)


def _rel(a: float, b: float) -> str:
    return f'{100.0 * (a - b) / b:+.2f} %'


def render(d: Derived, outdir: Path) -> Section:
    rows = [
        ('m_e (kg)', PAPER['m_e'], d.m_e, 'I1·I2/(I1·r2² + I2·r1²), tip radii 78 / 582 mm'),
        ('F_m (N)', PAPER['F_m'], d.F_m, '400 N·m / r1'),
        ('ω0 (rad/s)', PAPER['omega_0'], d.omega_0, '√(k_m/m_e), k_m = 1·10^7 N/m'),
        ('ω0 with m_e rounded to 5.150 (rad/s)', PAPER['omega_0'], d.omega_0_rounded,
         '√(10^7 / 5.150)'),
        ('ω_e (rad/s)', PAPER['omega_e'], d.omega_e, 'z1·ω1 = 24 × 24 r/min'),
        ('Ω', PAPER['Omega'], d.Omega, 'ω_e/ω0'),
        ('f0', PAPER['f0'], d.f0, 'F_m/(k_m·l), l = 1 µm'),
        ('ζ', PAPER['zeta'], d.zeta, 'c/(2·m_e·ω0), c = 717.5 N·s/m'),
        ("k_a'", PAPER['ka'], d.ka, 'k_a/k_m, k_a = 10^6 N/m'),
    ]
    main = table(('quantity', 'paper', 'recomputed', 'difference', 'how'),
                 ((q, f'{a:.10g}', fmt(b, 6), _rel(b, a), how) for q, a, b, how in rows))
    implied = table(('input the paper does not state', 'value that reproduces its numbers',
                     'how'), (
        ('radii r1, r2', '78 mm, 582 mm (tip radii)', 'only these give m_e = 5.150 kg'),
        ('mean mesh stiffness k_m', f'{fmt(d.k_m_implied, 6)} N/m', 'ω0² · m_e (printed values)'),
        ('length scale l', f'{fmt(d.length_scale * 1e6, 4)} µm', 'F_m/(k_m·f0)'),
        ('STE amplitude ε_1', f'{fmt(d.ste_amplitude * 1e3, 5)} mm', 'fa·l'),
    ))
    radii = table(('radius convention', 'r1 (mm)', 'r2 (mm)', 'm_e (kg)'),
                  ((name, fmt(r1 * 1e3, 4), fmt(r2 * 1e3, 4), fmt(me, 5))
                   for name, (r1, r2, me) in d.m_e_by_radius.items()))
    body = f"""
The paper prints the derived numbers of its example but not all the inputs. The project's
parameter functions (`params.py`) recompute them from `TableParams()` (the paper's example):

{main}

The inputs these numbers imply (model.md §6):

{implied}

The paper calls r_i the *base* radius, but only the *tip* radius reproduces its m_e:

{radii}

The pinion inertia tells the same story: a solid disc of the stated mass M1 = 10.70 kg with
the tip radius has M1·r1²/2 = {fmt(d.pinion_inertia_disc, 4)} kg·m² (paper: 3.255·10^-2).
The paper's ω0 = 1393.466 rad/s is √(10^7/5.150): it was computed from the *rounded* m_e;
with the unrounded 5.1477 kg it is {fmt(d.omega_0, 6)} rad/s (0.02 % higher), and Ω is
{fmt(d.Omega, 4)} instead of 0.04329. The STE amplitude ε_1 = {fmt(d.ste_amplitude * 1e3, 4)} mm
implied by fa = 1538.4 is about a hundred times what a module-6 gear of any quality class
shows (tens of µm); at the paper's speed its inertial forcing m_e·ε_1·ω_e² is only
{fmt(d.ste_forcing, 3)} N against F_m = 5128 N, so it hardly matters there (sections 2–4),
but it dominates at higher speeds (section 9).
"""
    verdicts = [
        Verdict('m_e = 5.150 kg', '5.150 kg', f'{fmt(d.m_e, 5)} kg', HOLDS,
                'with the tip radii, not the base radii the text names'),
        Verdict('F_m = 5128 N', '5128 N', f'{fmt(d.F_m, 5)} N', HOLDS, 'r1 = 78 mm'),
        Verdict('ω0 = 1393.466 rad/s', '1393.466 rad/s', f'{fmt(d.omega_0, 7)} rad/s', HOLDS,
                'to 0.02 %; exact with k_m = 10^7 N/m and m_e rounded to 5.150 kg'),
        Verdict('ω_e = 60.319 rad/s', '60.319 rad/s', f'{fmt(d.omega_e, 5)} rad/s', HOLDS),
        Verdict('Ω = 0.043, f0 = 512.8, fa = 1538.4', '0.043, 512.8, 1538.4',
                f'{fmt(d.Omega, 4)}, {fmt(d.f0, 4)}, fa = ε_1/l', HOLDS,
                'with k_m = 10^7 N/m and l = 1 µm, neither stated'),
        Verdict('inputs of the example', 'k_m, l, ε_1 not stated', '10^7 N/m, 1 µm, 1.54 mm',
                VAGUE, 'ε_1 = 1.54 mm is implausibly large for a module-6 gear'),
    ]
    return Section(1, 'Derived quantities of the worked example', body, [], verdicts)


__all__ = ['PAPER', 'Derived', 'compute', 'render']
