"""Section 6: the paper's "stability map" against Floquet theory and harmonic distortion."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.patches import Rectangle
from matplotlib.ticker import MaxNLocator

from . import floquet
from .common import COLORS, FAILS, VAGUE, Section, Verdict, agreement, plt, save_figure, table
from .index import grid
from .measures import quasi_static_thd
from .steady import SteadyMap, steady_map

PAPER_OMEGA = 0.043
PAPER_ZETA = 0.05
#: The paper's region of "stable harmonic response": ζ > 0.08 and k_a' < 0.3.
REGION_ZETA, REGION_KA = 0.08, 0.3


@dataclass(frozen=True)
class StabilityStudy:
    zetas: np.ndarray
    kas: np.ndarray
    radius: np.ndarray           # max |μ| at Ω = 0.043 over ζ × k_a'
    excess: np.ndarray           # Floquet exponent + ζ: what the stiffness fluctuation adds
    margin: np.ndarray           # −(largest Floquet exponent): damping-ratio margin, < 0 unstable
    omegas: np.ndarray
    tongue_kas: np.ndarray
    tongue_growth: np.ndarray    # Floquet exponent at ζ = 0.05 over Ω × k_a'
    thresholds: dict             # tongue label → (Ω at onset, smallest unstable k_a')
    steady: SteadyMap            # THD of the forced response over ζ × k_a'
    region_thd: float            # THD on the region's edge k_a' = 0.3 (measured)


def _threshold(omegas: np.ndarray, kas: np.ndarray, growth: np.ndarray,
               lo: float, hi: float) -> tuple[float, float]:
    """(Ω, k_a') of the lowest unstable k_a' with Ω in [lo, hi] (nan if none)."""
    band = (omegas >= lo) & (omegas <= hi)
    unstable = growth[band] > 0.0
    if not np.any(unstable):
        return math.nan, math.nan
    first = np.argmax(unstable, axis=1).astype(float)
    first[~np.any(unstable, axis=1)] = np.inf
    i = int(np.argmin(first))
    return float(omegas[band][i]), float(kas[int(first[i])])


def compute(quick: bool = False) -> StabilityStudy:
    n_z, n_k = (6, 6) if quick else (40, 51)
    zetas = np.linspace(0.01, 0.2, n_z)
    kas = np.linspace(0.0, 0.5, n_k)
    m = floquet.monodromy(zetas[:, None], kas[None, :], PAPER_OMEGA, progress='Floquet map')
    growth = floquet.growth_rate(m, PAPER_OMEGA)
    omegas = np.linspace(0.05, 3.0, 40 if quick else 240)
    tongue_kas = np.linspace(0.0, 0.5, 11 if quick else 51)
    mt = floquet.monodromy(PAPER_ZETA, tongue_kas[None, :], omegas[:, None],
                           progress='Floquet tongues')
    tongue_growth = floquet.growth_rate(mt, omegas[:, None])
    thresholds = {'Ω ≈ 2 (principal)': _threshold(omegas, tongue_kas, tongue_growth, 1.6, 2.6),
                  'Ω ≈ 1 (second)': _threshold(omegas, tongue_kas, tongue_growth, 0.8, 1.2),
                  'Ω ≈ 2/3 (third)': _threshold(omegas, tongue_kas, tongue_growth, 0.55, 0.75)}
    sz, sk = grid(quick)
    sm = steady_map(sz, sk)
    region_thd = float(np.interp(REGION_KA, sm.kas, sm.thd.mean(axis=0)))
    return StabilityStudy(zetas, kas, floquet.spectral_radius(m), growth + zetas[:, None],
                          -growth,
                          omegas, tongue_kas, tongue_growth, thresholds, sm, region_thd)


def _region(ax, xmax: float) -> None:
    ax.add_patch(Rectangle((REGION_ZETA, 0.0), xmax - REGION_ZETA, REGION_KA, fill=False,
                           hatch='//', edgecolor=COLORS[4], lw=1.5,
                           label="paper's region ζ > 0.08, k_a' < 0.3"))


MARGIN_CMAP = 'RdBu'   # red: unstable (negative margin), white: the boundary, blue: stable


def _centred(values: np.ndarray) -> TwoSlopeNorm:
    """A colour norm with white exactly at the stability boundary ζ_eq = 0."""
    span = float(np.max(np.abs(values)))
    return TwoSlopeNorm(vmin=-span, vcenter=0.0, vmax=span)


def _diverging_levels(values: np.ndarray) -> np.ndarray:
    """Contour levels symmetric about 0, so that one level is the boundary itself."""
    span = float(np.max(np.abs(values)))
    return np.linspace(-span, span, 21)


def _margin_bar(fig, cs, ax) -> None:
    bar = fig.colorbar(cs, ax=ax, label='damping margin ζ_eq = −(largest Floquet exponent)\n'
                                        '> 0 stable (blue), < 0 unstable (red)')
    bar.locator = MaxNLocator(nbins=4, symmetric=True)
    bar.update_ticks()


def render(s: StabilityStudy, outdir: Path) -> Section:
    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    ax = axes[0]
    z, k = np.meshgrid(s.zetas, s.kas, indexing='ij')
    margin = s.margin
    cs = ax.contourf(z, k, margin, levels=_diverging_levels(margin), cmap=MARGIN_CMAP,
                     norm=_centred(margin))
    _margin_bar(fig, cs, ax)
    _region(ax, s.zetas[-1])
    ax.set(xlabel='damping ratio ζ', ylabel="stiffness fluctuation k_a'",
           title=f'Stability margin at Ω = {PAPER_OMEGA}: stable everywhere (ζ_eq = ζ)')
    ax.legend(loc='upper right', fontsize=8)
    ax = axes[1]
    o, kk = np.meshgrid(s.omegas, s.tongue_kas, indexing='ij')
    # The same reading over Ω: the margin drops from ζ inside the tongues of the Hill
    # equation and turns negative (red) where the parametric growth beats the damping.
    tongue_margin = -s.tongue_growth
    cs = ax.contourf(o, kk, tongue_margin, levels=_diverging_levels(tongue_margin),
                     cmap=MARGIN_CMAP, norm=_centred(tongue_margin), extend='both')
    _margin_bar(fig, cs, ax)
    ax.contour(o, kk, s.tongue_growth, levels=[0.0], colors='black', linewidths=1.5)
    ka_line = np.linspace(4 * PAPER_ZETA, 0.5, 100)
    half = np.sqrt(ka_line ** 2 / 4 - 4 * PAPER_ZETA ** 2)
    ax.plot(2 - half, ka_line, '--', color='black', lw=1.2,
            label='first-order tongue |Ω − 2| < √(k²/4 − 4ζ²)')
    ax.plot(2 + half, ka_line, '--', color='black', lw=1.2)
    ax.axvline(PAPER_OMEGA, color=COLORS[4], lw=2, label=f'paper: Ω = {PAPER_OMEGA}')
    ax.axhline(REGION_KA, color='black', ls=':', lw=1.2, label="paper: k_a' = 0.3")
    ax.plot([], [], color='black', lw=1.5, label='stability boundary (ζ_eq = 0)')
    ax.set(xlabel='frequency ratio Ω = ω_e/ω0', ylabel="stiffness fluctuation k_a'",
           title=f'Instability tongues at ζ = {PAPER_ZETA} (unstable: red, inside black line)')
    ax.legend(loc='lower right', fontsize=7.5)
    ax = axes[2]
    sz, sk = np.meshgrid(s.steady.zetas, s.steady.kas, indexing='ij')
    cs = ax.contourf(sz, sk, 100 * s.steady.thd, levels=20, cmap='magma')
    fig.colorbar(cs, ax=ax, label='THD of the steady response (%)')
    lines = ax.contour(sz, sk, 100 * s.steady.thd, levels=[5, 10, 15, 20, 25], colors='cyan',
                       linewidths=0.8)
    ax.clabel(lines, fmt='%.0f %%', fontsize=8)
    _region(ax, s.steady.zetas[-1])
    ax.set(xlabel='damping ratio ζ', ylabel="stiffness fluctuation k_a'",
           title='Harmonic distortion of the forced response, Ω = 0.043')
    ax.legend(loc='upper right', fontsize=8)
    fig.tight_layout()
    name, link = save_figure(fig, outdir, 'fig06_stability.png',
                             'Floquet map, instability tongues and distortion map')
    rows = [(label, f'{om:.3f}' if not math.isnan(om) else '–',
             f'{ka:.2f}' if not math.isnan(ka) else 'none ≤ 0.5')
            for label, (om, ka) in s.thresholds.items()]
    tongues = table(('tongue (ζ = 0.05)', 'Ω at onset', "smallest unstable k_a'"), rows)
    body = f"""
The homogeneous equation x'' + 2ζx' + [1 + k_a'·cos Ωτ]x = 0 is linear with period 2π/Ω,
so its Floquet multipliers μ (eigenvalues of the monodromy matrix, `floquet.py`) decide
stability exactly. Three readings of the paper's "stability map", with its region
(ζ > 0.08, k_a' < 0.3, hatched) drawn where it applies:

{link}

* **Floquet at the paper's Ω = 0.043** (left): max|μ| < 1 on the whole grid, ζ from 0.01 to
  0.2 and k_a' from 0 to 0.5. The multipliers are the plain damping decay e^(−2πζ/Ω): the
  largest Floquet exponent λ equals −ζ {agreement(float(np.max(np.abs(s.excess))))}. The colour is
  the stability margin read as a damping ratio, ζ_eq = −λ (a free vibration decays like
  e^(−ζ_eq·ω0·t); ζ_eq < 0 grows, red): here ζ_eq = ζ, the stiffness fluctuation takes none
  of the damping away. The mesh
  frequency is 23 times below the natural frequency; parametric resonance needs Ω ≈ 2/n
  (n = 1, 2, …), whose tongues at n ≈ 46 have no measurable width. Nothing changes at ζ = 0.08
  or k_a' = 0.3.
* **Instability tongues** (middle, ζ = 0.05): parametric resonance appears only near Ω = 2/n:

{tongues}

  The principal tongue opens at k_a' ≈ 4ζ = 0.2 as first-order theory says (dashed). Read
  as a damping margin, the fluctuation k_a' = 0.5 at Ω ≈ 2 leaves ζ_eq = {np.min(-s.tongue_growth):.3f}
  (the mesh damping ζ = {PAPER_ZETA} minus a parametric growth of {PAPER_ZETA - np.min(-s.tongue_growth):.3f}),
  while the paper's Ω keeps the full ζ_eq = {PAPER_ZETA}.
  The paper's operating point Ω = 0.043 is far from all of them.
* **Harmonic distortion of the forced response** (right): THD depends on k_a' alone (the
  contours are horizontal; section 4 gives its closed form). The paper's k_a' < 0.3 edge is
  the contour THD ≈ {100 * s.region_thd:.1f} % (closed form {100 * quasi_static_thd(REGION_KA):.1f} %); its ζ > 0.08 edge
  matches no property of the steady response. The only thing ζ = 0.08 marks is a
  transient: the 1 % settling time ln(100)/0.08 = {math.log(100) / 0.08:.0f} (section 3).

So the paper's region matches none of the readings as a stability boundary: the response
is stable everywhere on its map. Read as "harmonic response", its k_a' bound is a
distortion threshold of about 16 % THD and its ζ bound is a settling-time preference.
"""
    verdicts = [
        Verdict('stable harmonic response for ζ > 0.08 and k_a\' < 0.3', 'a stability map',
                'Floquet-stable on the whole map (max|μ| < 1 for all ζ > 0, k_a\' ≤ 0.5)',
                FAILS, 'not a stability boundary; instability needs Ω ≈ 2/n, e.g. Ω ≈ 2 with k_a\' > 4ζ'),
        Verdict("the region's k_a' < 0.3 edge", 'harmonic inside',
                f'THD = {100 * s.region_thd:.1f} % on the edge, independent of ζ', VAGUE,
                'matches a distortion threshold of ≈ 16 % THD'),
        Verdict("the region's ζ > 0.08 edge", 'harmonic inside',
                'THD and stability independent of ζ', FAILS,
                f'only a transient criterion: τ_s < {math.log(100) / 0.08:.0f}'),
    ]
    return Section(6, 'Stability map', body, [name], verdicts)


__all__ = ['StabilityStudy', 'compute', 'render']
