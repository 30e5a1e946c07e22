"""Section 12: the table's frequency response and modes, for the design of a position loop.

The linear model of :mod:`screwgear_ros.design.linearize` at the preload equilibrium (its
modes beside the paper's 1-DOF ω0), the response measured by simulation around the
default operating point of ``frequency_response`` (:mod:`screwgear_ros.design.frequency`),
and how the preload torque, the preload stiffness and k_a' move the resonance: the linear
model's mode, the mode of the model frozen at the rest angle (``linearize(...,
mesh='frozen')``), and the peak of the measured table acceleration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..design.frequency import Input, Measurement, default_bias, measure
from ..design.linear_model import OUTPUTS, ModeInfo
from ..design.linearize import linearize
from ..params.table import TableParams
from ..physics.quantities import natural_frequency
from .common import HOLDS, Section, Verdict, fmt, save_figure, table

#: Amplitude of the drive torque sine, N·m (the executable's default).
AMPLITUDE = 10.0
AGAINST_TABLE = 'pinions against the table'
#: The paper's preload torque, N·m: its case is the paper's table.
PAPER_PRELOAD = TableParams().preload_torque


@dataclass(frozen=True)
class Case:
    label: str
    linear_hz: float          # the linear model's "pinions against the table" mode, Hz
    frozen_hz: float          # the same mode of the model frozen at the rest angle, Hz
    measured_hz: float        # peak of the measured torque → table acceleration, Hz


@dataclass(frozen=True)
class DesignStudy:
    omega0: float                       # the paper's √(k_m/m_e), rad/s
    modes: list[ModeInfo]               # linear model at the preload equilibrium
    bode: Measurement                   # the paper's table, torque → table angle and TE
    preload: list[Case]
    preload_stiffness: list[Case]
    fluctuation: list[Case]
    conventional: float                 # the one mesh mode in conventional mode, rad/s


def frozen_modes(params: TableParams, torque: float, load: float) -> np.ndarray:
    """Natural frequencies, rad/s, of the oscillating modes of the full model frozen at its
    rest angle under ``torque`` against ``load`` (``linearize(..., mesh='frozen')``)."""
    return np.array([m.frequency for m in linearize(params, torque, load, 1, 'frozen').modes()
                     if m.oscillating])


def _peak(frequency: np.ndarray, magnitude: np.ndarray) -> float:
    """The peak of a sampled curve (a parabola in log–log through the top three); NaN
    when the largest sample is at an end (no peak inside the band)."""
    k = int(np.argmax(magnitude))
    if not 0 < k < len(magnitude) - 1:
        return math.nan
    x, y = np.log(frequency[k - 1:k + 2]), np.log(magnitude[k - 1:k + 2])
    a, b, _ = np.polyfit(x, y, 2)
    return float(np.exp(-b / (2.0 * a))) if a < 0 else float(frequency[np.argmax(magnitude)])


def _case(label: str, params: TableParams, quick: bool) -> Case:
    torque, load = default_bias(params, Input.TORQUE, AMPLITUDE, None, None, 1)
    model = linearize(params, torque, load)
    linear = next(m.hz for m in model.modes() if m.shape == AGAINST_TABLE)
    frozen = frozen_modes(params, torque, load)
    frozen_hz = float(frozen[-1]) / (2.0 * math.pi) if frozen.size else math.nan
    # the band is centred on the frozen model's mode; the peak is found in the measurement
    centre = frozen_hz if math.isfinite(frozen_hz) else linear
    band = np.linspace(0.85 * centre, 1.15 * centre, 11 if quick else 21)
    m = measure(params, outputs=('table_angle',), frequencies=list(band), amplitude=AMPLITUDE)
    accel = np.abs(m.measured[0]) * (2.0 * math.pi * m.frequency) ** 2
    return Case(label, linear, frozen_hz, _peak(m.frequency, accel))


def compute(quick: bool = False) -> DesignStudy:
    paper = TableParams()
    modes = linearize(paper).modes()
    bode = measure(paper, outputs=('table_angle', 'transmission_error'),
                   frequencies=list(np.geomspace(1.0, 500.0, 12 if quick else 40)),
                   amplitude=AMPLITUDE)
    preloads = (100.0, PAPER_PRELOAD) if quick else (100.0, 200.0, PAPER_PRELOAD, 600.0)
    stiffnesses = (0.0, 1e7) if quick else (0.0, 2e6, 5e6, 1e7)
    fluctuations = (0.0, 0.2) if quick else (0.0, 0.1, 0.2, 0.3)
    return DesignStudy(
        natural_frequency(paper), modes, bode,
        [_case(f'T_p = {tp:g} N·m', paper.replace(preload_torque=tp), quick)
         for tp in preloads],
        [_case(f'k_p = {fmt(kp, 2)} N/m', paper.replace(preload_stiffness=kp), quick)
         for kp in stiffnesses],
        [_case(f"k_a' = {ka:g}",
               paper.replace(mesh_stiffness_amplitude=ka * paper.mesh_stiffness_mean), quick)
         for ka in fluctuations],
        next(m.frequency for m in linearize(paper.replace(mode='conventional'), AMPLITUDE,
                                            AMPLITUDE * paper.radius_table
                                            / paper.radius_pinion_1).modes()
             if m.oscillating))


def _cases(cases: list[Case], first: str) -> str:
    return table((first, 'linear model (Hz)', 'frozen at the rest angle (Hz)',
                  'measured peak (Hz)'),
                 ((c.label, f'{c.linear_hz:.1f}', f'{c.frozen_hz:.1f}', f'{c.measured_hz:.1f}')
                  for c in cases))


def _draw_frozen(fig, bode: Measurement) -> None:
    """The model frozen at the rest angle, dashed, on the Bode plot's axes (row-major:
    the magnitudes, then the phases)."""
    point = bode.model.point
    frozen = linearize(bode.model.params, point.torque, point.load, point.direction, 'frozen')
    f = np.geomspace(bode.frequency[0], bode.frequency[-1], 600)
    response = frozen.response(f)[:, 0, :]
    n = len(bode.outputs)
    for i, name in enumerate(bode.outputs):
        row = OUTPUTS.index(name)
        mag, ph = fig.axes[i], fig.axes[n + i]
        mag.loglog(f, np.abs(response[row]), color='C4', ls='--', lw=1.2,
                   label='linear, mesh frozen at the rest angle')
        phase = np.degrees(np.unwrap(np.angle(response[row])))
        # on the branch of the averaged model's curve at the lowest frequency
        ref = np.degrees(np.angle(bode.model.response(f[:1])[row, 0, 0]))
        lines = [ln for ln in ph.get_lines() if ln.get_color() == 'C0']
        if lines:
            ref = float(lines[0].get_ydata()[0])
        phase += 360.0 * np.round((ref - phase[0]) / 360.0)
        ph.semilogx(f, phase, color='C4', ls='--', lw=1.2)
    fig.axes[0].legend(fontsize=7, loc='lower left')


def render(s: DesignStudy, outdir: Path) -> Section:
    fig = s.bode.figure()
    _draw_frozen(fig, s.bode)
    name, link = save_figure(fig, outdir, 'fig12_bode.png',
                             "Bode plot of the paper's table, drive torque to table angle and "
                             'transmission error, measured and linear')
    oscillating = [m for m in s.modes if m.oscillating]
    modes = table(('mode', 'ω_n (rad/s)', 'f_n (Hz)', 'ζ', 'shape'),
                  ((i, f'{m.frequency:.1f}', f'{m.hz:.2f}',
                    f'{m.damping:.4f}' if m.frequency else '—', m.shape)
                   for i, m in enumerate(s.modes, start=1)))
    w = [m.frequency for m in oscillating]
    rms = math.sqrt(sum(x * x for x in w) / len(w)) if w else math.nan
    point = s.bode.model.point
    paper = next(c for c in s.preload if c.label == f'T_p = {PAPER_PRELOAD:g} N·m')
    body = f"""
`linearize` at the preload equilibrium of the paper's table (both meshes on their flanks,
the mesh taken as its time average: k_eff = {fmt(s.bode.model.params.mesh_stiffness_mean, 3)}
N/m, lever r, no STE):

{modes}

The paper's 1-DOF model (the pinion–table pair) has ω0 = √(k_m/m_e) = {s.omega0:.1f} rad/s.
The 3-DOF table splits it into two modes: {w[0]:.1f} rad/s with the two pinions swinging
against each other while the table stands (ω² = k·r1²/I1, a pinion on one mesh against a
still table) and {w[1]:.1f} rad/s with both pinions against the table (ω² = k·r1²/I1 +
2·k·r2²/I2). ω0² = k·(r1²/I1 + r2²/I2) is exactly the mean of the two ω² (rms
{rms:.1f} rad/s): the paper's number is right to {100 * max(abs(x / s.omega0 - 1) for x in w):.1f} %
for either mode, and it is exactly the one mesh mode of the conventional gear (pinion 1
alone on the table: {s.conventional:.1f} rad/s), the system the 1-DOF model describes. In
this symmetric model the table takes no part in the lower one, so a
drive torque reaches the table angle through the upper one and the rigid body (0, the
double integrator a position loop closes around).

Measured by simulation (`frequency_response`, stepped sines of {AMPLITUDE:g} N·m around a
bias of {point.torque:g} N·m against the load {point.load:.1f} N·m that holds the table at
rest, each point settled then fitted over whole periods), the paper's full table (STE
ε₁ = 1.54 mm, k_a' = 0.1, backlash 75 µm, `angle` mesh phase):

{link}

Below about 100 Hz the table angle follows the linear model (the rigid body, (r2/r1)/(J·ω²)).
The measured resonance lies below the linear mode: standing still, the mesh phase does not
sweep, so the pinion works on the mesh through the stiffness and the lever at its rest angle,
K(φ0) and r − z·dε/dφ(φ0), not through their averages. The model frozen at the rest angle
(`linearize --mesh frozen`, dashed) puts the mode where the measurement finds it. The transmission error at low frequencies is the STE itself, swept by the large table
motion, not the mesh deflection (its points there are hollow where the fitted sinusoid
explains little of it). For a position loop around this table at rest, the resonance to
keep the crossover away from is the measured {paper.measured_hz:.0f} Hz (the frozen model's
{paper.frozen_hz:.0f} Hz), not the averaged model's {paper.linear_hz:.0f} Hz; below it the
plant is the rigid body, −180° of phase.

How the resonance (torque → table acceleration) moves:

{_cases(s.preload, 'preload torque')}

{_cases(s.preload_stiffness, 'preload stiffness')}

{_cases(s.fluctuation, "stiffness fluctuation")}

The time-averaged model depends on k_eff only: the preload torque and k_a' do not move its
modes, k_p moves them as √k_eff. At rest they do move the real one: the preload torque sets
the rest angle, hence φ0, the local stiffness K(φ0) = k_eff + k_a·cos φ0 and the local lever;
k_a' sets how far K(φ0) is from k_eff.
"""
    verdicts = [Verdict(
        "ω0 = √(k_m/m_e) is the table's mesh natural frequency", f'{s.omega0:.1f} rad/s',
        f'3-DOF modes {w[0]:.0f} and {w[1]:.0f} rad/s (ω0² their mean)', HOLDS,
        f'within {100 * max(abs(x / s.omega0 - 1) for x in w):.1f} % for both mesh modes of '
        'the averaged model; at rest the STE lever moves the measured one')]
    return Section(12, 'Frequency response and modes for a position loop (beyond the paper)',
                   body, [name], verdicts)


__all__ = ['AMPLITUDE', 'Case', 'DesignStudy', 'compute', 'frozen_modes', 'render']
