"""The Bode plots of the design tools: an open-loop response beside the linear model's,
and a measured loop with its margins.

Magnitudes are in dB. Phases are unwrapped from their low-frequency asymptote: the linear
model's phase at the lowest frequency is taken on the branch in (−270°, 90°] (a gain 0°,
an integrator −90°, the rigid body's double integrator −180°, never +180°) and followed
from there; the measured points are unwrapped along frequency from the branch nearest
that curve. A measured point whose coherence is below ``TRUST`` (an output that is not a
sinusoid at the drive frequency: its phase scatters by ±180°) is drawn grey and hollow,
on the branch nearest the trusted points around it, and takes no part in the unwrapping.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .linear_model import OUTPUT_UNITS, OUTPUTS
from .margins import loop_phase

#: Coherence below which a measured point is drawn grey (not to be trusted).
TRUST = 0.9
#: Colour of the untrusted points.
GREY = '0.6'


def db(values: np.ndarray) -> np.ndarray:
    """20·log10 |values|."""
    with np.errstate(divide='ignore'):
        return 20.0 * np.log10(np.abs(values))


def asymptotic_phase(response: np.ndarray) -> np.ndarray:
    """The phase of ``response`` (rising frequencies) in degrees, unwrapped, its first
    value on the branch (−270°, 90°] (module docstring)."""
    phase = np.degrees(np.unwrap(np.angle(response)))
    return phase - 360.0 * np.ceil((phase[0] - 90.0) / 360.0)


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Degrees into (−180, 180]."""
    return -((-np.asarray(angle) + 180.0) % 360.0 - 180.0)


def measured_phase(frequency: np.ndarray, measured: np.ndarray, trusted: np.ndarray,
                   guide_hz: np.ndarray, guide_phase: np.ndarray) -> np.ndarray:
    """The measured phases in degrees: the trusted ones unwrapped along frequency from the
    branch of ``guide_phase`` (the linear curve, on ``guide_hz``) at the first of them;
    each untrusted one on the branch nearest the trusted phase interpolated at it."""
    raw = np.degrees(np.angle(measured))
    out = raw.copy()
    guide = np.interp(np.log(frequency), np.log(guide_hz), guide_phase)
    good = np.flatnonzero(trusted)
    if len(good):
        chain = np.degrees(np.unwrap(np.radians(raw[good])))
        chain += 360.0 * np.round((guide[good[0]] - chain[0]) / 360.0)
        out[good] = chain
        reference = np.interp(np.log(frequency), np.log(frequency[good]), chain)
    else:
        reference = guide
    bad = np.flatnonzero(~trusted)
    out[bad] = reference[bad] + _wrap(raw[bad] - reference[bad])
    return out


def _points(ax: Any, f: np.ndarray, values: np.ndarray, trusted: np.ndarray, color: str,
            label: str | None, grey_label: str | None) -> None:
    if trusted.any():
        ax.semilogx(f[trusted], values[trusted], 'o', ms=4, color=color, label=label)
    if (~trusted).any():
        ax.semilogx(f[~trusted], values[~trusted], 'o', ms=4, mfc='none', mec=GREY,
                    label=grey_label)


def measurement_figure(m: Any, column: int, input_unit: str) -> Any:
    """A Bode plot of a :class:`~.frequency.Measurement` (input column ``column`` of the
    linear model): magnitude (dB) and phase of each output, measured (markers; grey where
    the coherence is below ``TRUST``) and linear (lines), the oscillating modes marked."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    n = len(m.outputs)
    fig, axes = plt.subplots(2, n, figsize=(5.6 * n, 6.6), squeeze=False, sharex=True)
    fine = (np.geomspace(m.frequency[0], m.frequency[-1], 600) if len(m.frequency) > 1
            else m.frequency)
    dense = m.model.response(fine)[:, column, :]
    modes = [mode for mode in m.model.modes() if mode.oscillating
             and m.frequency[0] <= mode.hz <= m.frequency[-1]]
    for i, name in enumerate(m.outputs):
        row = OUTPUTS.index(name)
        mag, ph = axes[0, i], axes[1, i]
        trusted = m.coherence[i] >= TRUST
        line_phase = asymptotic_phase(dense[row])
        mag.semilogx(fine, db(dense[row]), color='C0', label='linear model')
        ph.semilogx(fine, line_phase, color='C0')
        label = f'measured ({m.method.value}, {m.amplitude:g} {input_unit})'
        grey = f'measured, coherence < {TRUST:g}'
        _points(mag, m.frequency, db(m.measured[i]), trusted, 'C3', label, grey)
        _points(ph, m.frequency, measured_phase(m.frequency, m.measured[i], trusted, fine,
                                                line_phase), trusted, 'C3', None, None)
        for c, mode in enumerate(modes):
            for ax in (mag, ph):
                ax.axvline(mode.hz, color=f'C{c + 1}', lw=0.9, ls='--',
                           label=(f'{mode.hz:.1f} Hz, ζ {mode.damping:.3f}: {mode.shape}'
                                  if ax is mag else None))
        unit = OUTPUT_UNITS[row]
        mag.set_title(f'{m.input.value} → {name}', fontsize=10)
        mag.set_ylabel(f'|H|, dB re 1 {unit}/{input_unit}')
        ph.set_ylabel('phase, °')
        ph.set_xlabel('frequency, Hz')
        for ax in (mag, ph):
            ax.grid(True, which='both', alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc='lower left')
    fig.tight_layout()
    return fig


def _beside(f: np.ndarray, curve: np.ndarray, at_hz: float, level: float) -> dict:
    """Where a margin's label goes: beside its arrow at ``level``, on the side (an octave
    left or right of ``at_hz``) where ``curve`` stays further from that level."""
    if len(f) < 2:
        return {'xytext': (8, 0), 'ha': 'left'}
    logf = np.log(f)
    left, right = (np.interp(math.log(at_hz) + d, logf, curve) for d in (-0.7, 0.7))
    if abs(right - level) >= abs(left - level):
        return {'xytext': (8, 0), 'ha': 'left'}
    return {'xytext': (-8, 0), 'ha': 'right'}


def loop_figure(loop: Any, trust: float = TRUST) -> Any:
    """Bode plot of a :class:`~.closed_loop.LoopMeasurement`: the loop gain's magnitude
    (dB) and phase with the gain and phase margins marked (the phase margin's label below
    the −180° line, where a stable loop's phase is not near its crossover), and the
    sensitivity's magnitude with its peak marked (its label above the peak); measured (markers, grey where the coherence is low)
    and with the linear plant (lines through the same frequencies)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    r = loop.response
    f = r.frequency
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 10.0), sharex=True)
    mag, ph, sens = axes
    lin_phase = loop_phase(r.linear[0])        # as the margins read it: from (−360°, 0°]
    mag.semilogx(f, db(r.linear[0]), color='C0', label='with the linear plant')
    ph.semilogx(f, lin_phase, color='C0')
    sens.semilogx(f, db(r.linear[1]), color='C0')
    trusted = r.coherence[0] >= trust
    label, grey = 'measured', f'measured, coherence < {trust:g}'
    _points(mag, f, db(r.measured[0]), trusted, 'C3', label, grey)
    _points(ph, f, measured_phase(f, r.measured[0], trusted, f, lin_phase), trusted, 'C3',
            None, None)
    _points(sens, f, db(r.measured[1]), r.coherence[1] >= trust, 'C3', None, None)
    for ax, level in ((mag, 0.0), (ph, -180.0), (sens, 0.0)):
        ax.axhline(level, color='0.4', lw=0.8)
    m = loop.margins
    if m.phase is not None:
        for ax in axes:
            ax.axvline(m.phase_at_hz, color='C2', ls='--', lw=0.9)
        ph.annotate('', xy=(m.phase_at_hz, -180.0 + m.phase), xytext=(m.phase_at_hz, -180.0),
                    arrowprops={'arrowstyle': '<->', 'color': 'C2'})
        ph.annotate(f'phase margin {m.phase:.1f}°\nat {m.phase_at_hz:.3g} Hz',
                    (m.phase_at_hz, -180.0), xytext=(6, -4), textcoords='offset points',
                    ha='left', va='top', fontsize=8, color='C2')
    # the upper gain margin; without one, the lower one of a conditionally stable loop
    gain, gain_hz, lower = ((m.gain, m.gain_at_hz, '') if m.gain is not None else
                            (m.lower_gain, m.lower_gain_at_hz,
                             '\n(lower: unstable if the gain drops)'))
    if gain is not None and gain_hz is not None:
        gm_db = 20.0 * math.log10(gain)
        for ax in axes:
            ax.axvline(gain_hz, color='C4', ls='--', lw=0.9)
        mag.annotate('', xy=(gain_hz, 0.0), xytext=(gain_hz, -gm_db),
                     arrowprops={'arrowstyle': '<->', 'color': 'C4'})
        mag.annotate(f'gain margin {gm_db:.1f} dB\nat {gain_hz:.4g} Hz{lower}',
                     (gain_hz, -0.5 * gm_db),
                     **_beside(f, db(r.linear[0]), gain_hz, -0.5 * gm_db),
                     textcoords='offset points', va='center', fontsize=8, color='C4')
    if m.peak_sensitivity is not None:
        peak_db = 20.0 * math.log10(m.peak_sensitivity)
        sens.plot([m.peak_at_hz], [peak_db], marker='v', ms=9, color='C1', ls='none')
        sens.annotate(f'peak |S| {m.peak_sensitivity:.2f} ({peak_db:.1f} dB)\nat '
                      f'{m.peak_at_hz:.4g} Hz', (m.peak_at_hz, peak_db), xytext=(0, 9),
                      textcoords='offset points', ha='center', va='bottom', fontsize=8,
                      color='C1')
        low, high = sens.get_ylim()
        sens.set_ylim(low, high + 0.3 * (high - low))    # room above the peak for its label
    fig.suptitle(f'loop of {loop.name} around the table, at the tick rate', fontsize=11)
    mag.set_title('loop gain L = −c/u: c the controller\'s effort, u = c + d what the plant '
                  'gets (d the injected sine)', fontsize=8.5)
    mag.set_ylabel('|L|, dB')
    ph.set_ylabel('∠L, °')
    sens.set_title('sensitivity S = u/d = 1/(1 + L)', fontsize=8.5)
    sens.set(ylabel='|S|, dB', xlabel='frequency, Hz')
    for ax in axes:
        ax.grid(True, which='both', alpha=0.3)
    mag.legend(fontsize=8, loc='lower left')
    fig.tight_layout()
    return fig


__all__ = ['GREY', 'TRUST', 'asymptotic_phase', 'db', 'loop_figure', 'measured_phase',
           'measurement_figure']
