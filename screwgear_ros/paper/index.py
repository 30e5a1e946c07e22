"""Section 5: the paper's performance index P = (ζ/k_a')·√k_m."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..physics.quantities import performance_index
from .common import COLORS, FAILS, VAGUE, Section, Verdict, fmt, plt, save_figure, table
from .steady import SteadyMap, steady_map

#: The paper's two examples: (ζ, k_a', k_m as printed in N/m, P as printed).
EXAMPLES = ((0.1, 0.1, 1e8, 3162.0), (0.05, 0.2, 1e8, 1118.0))
K_M = 1e7  # N/m, the stiffness of the paper's worked example


@dataclass(frozen=True)
class IndexStudy:
    examples: list               # (ζ, k_a', P printed, P at 1e8, P at 1e7, k_m implied)
    zetas: np.ndarray
    kas: np.ndarray
    index: np.ndarray            # P at k_m = 1e7 over the grid (inf at k_a' = 0)
    steady: SteadyMap            # measured steady state over the same grid
    settling: np.ndarray         # ln(100)/ζ, the 1 % settling time (section 3)


def grid(quick: bool) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The (ζ, k_a') grid of the maps of sections 5 and 6."""
    n_z, n_k = (6, 6) if quick else (20, 26)
    return (tuple(np.linspace(0.01, 0.2, n_z)), tuple(np.linspace(0.0, 0.5, n_k)))


def compute(quick: bool = False) -> IndexStudy:
    examples = []
    for zeta, ka, _, printed in EXAMPLES:
        examples.append((zeta, ka, printed, performance_index(zeta, ka, 1e8),
                         performance_index(zeta, ka, 1e7), (printed * ka / zeta) ** 2))
    zetas, kas = grid(quick)
    z, k = np.meshgrid(zetas, kas, indexing='ij')
    with np.errstate(divide='ignore'):
        p = np.where(k > 0, z / np.where(k > 0, k, 1.0) * math.sqrt(K_M), np.inf)
    return IndexStudy(examples, np.array(zetas), np.array(kas), p, steady_map(zetas, kas),
                      math.log(100.0) / np.array(zetas))


def render(s: IndexStudy, outdir: Path) -> Section:
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    z, k = np.meshgrid(s.zetas, s.kas, indexing='ij')
    ax = axes[0]
    zf, kf = np.meshgrid(np.linspace(s.zetas[0], s.zetas[-1], 200),
                         np.linspace(0.02, s.kas[-1], 200), indexing='ij')
    pf = zf / kf * math.sqrt(K_M)   # the formula on a fine grid, for smooth contours
    cs = ax.contourf(zf, kf, np.log10(pf), levels=20, cmap='viridis')
    fig.colorbar(cs, ax=ax, label='log10 P  (P in √(N/m), k_m = 10^7 N/m)')
    lines = ax.contour(zf, kf, pf, levels=[790.6, 1118, 3162], colors='white', linewidths=1)
    ax.clabel(lines, fmt='P = %.0f', fontsize=8)
    for i, (zeta, ka, printed, *_rest) in enumerate(s.examples):
        ax.plot(zeta, ka, 'o', ms=8, color=COLORS[1 + i],
                label=f'paper: ζ = {zeta}, k_a\' = {ka}, "P ≈ {printed:.0f}"')
    ax.set(xlabel='damping ratio ζ', ylabel="stiffness fluctuation k_a'",
           title='Performance index P = (ζ/k_a\')·√k_m')
    ax.legend(loc='upper center', bbox_to_anchor=(0.5, -0.14), fontsize=8)
    ax = axes[1]
    cs = ax.contourf(z, k, s.steady.amplitude, levels=20, cmap='magma')
    fig.colorbar(cs, ax=ax, label='steady-state amplitude of x (l = 1 µm)')
    ax.set(xlabel='damping ratio ζ', ylabel="stiffness fluctuation k_a'",
           title='Measured: steady-state vibration amplitude')
    ax = axes[2]
    settling = np.broadcast_to(s.settling[:, None], z.shape)
    cs = ax.contourf(z, k, np.log10(settling), levels=20, cmap='cividis')
    fig.colorbar(cs, ax=ax, label='log10 τ_s')
    lines = ax.contour(z, k, settling, levels=[25, 50, 100, 200], colors='white', linewidths=1)
    ax.clabel(lines, fmt='τ_s = %.0f', fontsize=8)
    ax.set(xlabel='damping ratio ζ', ylabel="stiffness fluctuation k_a'",
           title='Settling time τ_s = ln(100)/ζ (1 %, section 3)')
    fig.tight_layout()
    name, link = save_figure(fig, outdir, 'fig05_index.png',
                             'Performance index map beside the measured amplitude and settling time')
    rows = [(f'{zeta}', f'{ka}', f'{printed:.0f}', f'{p8:.1f}', f'{p7:.1f}', fmt(km, 3))
            for zeta, ka, printed, p8, p7, km in s.examples]
    tab = table(('ζ', "k_a'", 'paper P', 'P with k_m = 10^8 (text)', 'P with k_m = 10^7',
                 'k_m that gives the paper\'s P (N/m)'), rows)
    body = f"""
P = (ζ/k_a')·√k_m (`params.performance_index`), for the paper's two examples:

{tab}

The first example gives 3162 only with k_m = 10^7 N/m (the stiffness of the worked example),
not with the 10^8 N/m the text states. The second matches neither: the formula gives
2500 (10^8) or 790.6 (10^7); 1118 would need k_m = 2·10^7 N/m.

{link}

Beyond the arithmetic, P does not rank the dynamics the paper computes. Its level sets are
rays ζ/k_a' = const (left); the measured steady-state amplitude depends on k_a' alone
(middle: horizontal contours, quasi-static f0·k_a'/(1 − k_a'²)); the transient's settling time
depends on ζ alone (right: vertical contours, ln(100)/ζ). P also has units (√(N/m)), so its
value depends on the unit of k_m, and √k_m double-counts stiffness: k_a' = k_a/k_m and
ζ = c/(2√(k_m·m_e)) already contain k_m. A design check should use the two measures
separately: settling time ln(1/fraction)/ζ and steady amplitude ≈ f0·k_a'/(1 − k_a'²).
"""
    verdicts = [
        Verdict('P = 3162 for ζ = 0.1, k_a\' = 0.1, k_m = 10^8 N/m', '3162',
                f'{s.examples[0][3]:.0f} (10^8), {s.examples[0][4]:.1f} (10^7)', FAILS,
                'the number is right for k_m = 10^7 N/m, not the stated 10^8'),
        Verdict('P = 1118 for ζ = 0.05, k_a\' = 0.2, same k_m', '1118',
                f'{s.examples[1][3]:.0f} (10^8), {s.examples[1][4]:.1f} (10^7)', FAILS,
                'matches neither; would need k_m = 2·10^7 N/m'),
        Verdict('higher P means better dynamic stability', 'P ranks designs',
                "amplitude set by k_a' alone, settling time by ζ alone", VAGUE,
                'a definition, not a result: amplitude depends on k_a\' only, settling on ζ only'),
    ]
    return Section(5, 'Performance index P', body, [name], verdicts)


__all__ = ['EXAMPLES', 'IndexStudy', 'compute', 'grid', 'render']
