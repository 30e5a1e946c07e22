"""What the fitted model cannot explain: a residual analysis as MATLAB's ``resid`` makes
it, and a plain verdict.

For every fit recording and joint, the residual e (measured − simulated angle at each
sample's own time, after the fit) is compared with what the encoder alone would leave:
the noise floor √(σ_θ² + q²/12) of the base file's sensor (σ_θ its position noise, q
its count). The model **explains the data** when every joint's RMS residual is within
:data:`FLOOR_FACTOR` times that floor. It **does not** otherwise, and the analysis says
where: the joint, its RMS against the floor, and the tenth of the recording where the
residual is largest. The fit % is no guide here: a 99.999 % fit of a pinion that turns
five radians can still leave ten times the encoder's noise, a model error that shows
in everything built on it. A base file that declares no encoder noise nor counts has
no floor: :data:`IDEAL_FLOOR` stands in (the step grid's interpolation error).

Beside the verdict (reported, not judged, as ``resid`` plots them): the normalised
autocorrelation of each residual at lags 1 … :data:`LAGS`, and its cross-correlation
with the drive's command (cmd_effort, or cmd_torque with its direction) at lags
−:data:`LAGS` … :data:`LAGS`, against the 99 % band ±2.58/√N of white, independent
residuals: the share of lags outside the band.

A parameter that takes up what the model lacks moves when it is fitted to a part of
the recording: from the Jacobian J and residual r at the optimum, the Gauss–Newton step
of each half of the samples alone, −(J_hᵀJ_h)⁻¹J_hᵀr_h, is how far each parameter would
move (no further simulation). A parameter whose halves differ by more than its ±2σ
interval is flagged
(:data:`DRIFT` of them).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..interface import Input
from .parameters import FitParameter
from .problem import Comparison
from .samples import NODE_JOINTS
from .stats import Estimate, Statistics

#: Lags of the correlations (samples).
LAGS = 25
#: The 99 % band of a white residual's correlation: ±BAND/√N.
BAND = 2.58
#: RMS residual within this many noise floors: explained.
FLOOR_FACTOR = 3.0
#: A parameter whose half-fits differ by more than this many ±2σ half-widths drifts
#: (the difference of two half-fits has about one half-width's spread when the model is
#: right).
DRIFT = 4.0
#: The floor of an ideal encoder (no noise, no counts), rad.
IDEAL_FLOOR = 1.0e-9


@dataclass(frozen=True)
class JointResidual:
    recording: str
    joint: str
    rms: float                  # rad
    floor: float                # rad, the encoder's alone
    span: float                 # rad, the measured range
    worst_at: tuple[float, float]   # s from the start: the tenth where |e| is largest
    auto_outside: float         # share of lags 1..LAGS outside the band
    cross_outside: float        # share of lags −LAGS..LAGS outside the band (NaN: no input)

    @property
    def explained(self) -> bool:
        return self.rms <= FLOOR_FACTOR * self.floor


@dataclass(frozen=True)
class Analysis:
    joints: tuple[JointResidual, ...]
    drifting: tuple[tuple[str, float], ...]   # (parameter, half-to-half change / ±2σ)

    @property
    def explains(self) -> bool:
        return all(j.explained for j in self.joints)

    def verdict(self) -> str:
        """One line: the verdict, and where the model fails."""
        if self.explains:
            return ('the model explains the data: every joint\'s residual is within '
                    f'{FLOOR_FACTOR:g}× its encoder\'s noise and quantisation')
        bad = [j for j in self.joints if not j.explained]
        where = '; '.join(
            f'{j.joint} of {j.recording}: RMS {j.rms:.3g} rad = {j.rms / j.floor:.3g}× the '
            f'noise floor ({100 * j.rms / j.span:.3g} % of its range), largest at '
            f'{j.worst_at[0]:.3g}–{j.worst_at[1]:.3g} s' for j in bad[:3])
        return f'the model does NOT explain the data: {where}'

    def lines(self) -> list[str]:
        """The report's section (markdown)."""
        out = ['## Residual analysis', '', f'**Verdict: {self.verdict()}.**', '',
               (f'Correlations against the 99 % band ±{BAND}/√N of white residuals '
               f'(lags 1…{LAGS}; cross: with the drive command, lags ±{LAGS}).'), '',
               ('| recording | joint | RMS, rad | noise floor, rad | RMS / floor | % of range '
               '| autocorr. outside | cross-corr. outside | largest at, s |'),
               '|---|---|---|---|---|---|---|---|---|']
        for j in self.joints:
            cross = 'no input' if math.isnan(j.cross_outside) else \
                f'{100 * j.cross_outside:.0f} %'
            out.append(f'| `{j.recording}` | {j.joint} | {j.rms:.3g} | {j.floor:.3g} | '
                       f'{j.rms / j.floor:.3g} | {100 * j.rms / j.span:.3g} | '
                       f'{100 * j.auto_outside:.0f} % | {cross} | '
                       f'{j.worst_at[0]:.3g}–{j.worst_at[1]:.3g} |')
        if self.drifting:
            out += ['', ('Parameters that move with the part of the recording fitted (each '
                    'half alone, one Gauss–Newton step): they take up what the model lacks, '
                    'and their intervals do not hold:'), '']
            out += [f'- `{name}`: the halves differ by {ratio:.3g}× its ±2σ interval'
                    for name, ratio in self.drifting]
        return out + ['']


def verdict_lines(result: Any) -> list[str]:
    """What the terminal shows of an identify result's analysis and timing notes."""
    lines = [f'note: {note}' for note in getattr(result, 'notes', [])]
    analysis = getattr(result, 'analysis', None)
    if analysis is not None:
        lines.append(('' if analysis.explains else 'WARNING: ') + 'verdict: '
                     + analysis.verdict())
    return lines


def _correlation(a: np.ndarray, b: np.ndarray, lags: range) -> np.ndarray:
    a = a - a.mean()
    b = b - b.mean()
    norm = math.sqrt(float(a @ a) * float(b @ b))
    if norm == 0.0:
        return np.zeros(len(lags))
    n = len(a)
    return np.array([float(a[max(0, k):n + min(0, k)] @ b[max(0, -k):n - max(0, k)]) / norm
                     for k in lags])


def command_series(comparison: Comparison) -> np.ndarray | None:
    """The drive command (N·m, signed) held at each sample's time, None without one."""
    recording = comparison.recording
    times, values, direction = [], [], 1.0
    for t, topic, value in recording.inputs:
        if topic == Input.CMD_DIRECTION:
            direction = float(value)
            continue
        if topic == Input.CMD_EFFORT:
            u = float(value[0]) if len(value) else 0.0
        elif topic == Input.CMD_TORQUE:
            u = float(value) * direction
        elif topic == Input.JOINT_COMMANDS and len(value.effort):
            u = float(value.effort[0])
        else:
            continue
        times.append(t)
        values.append(u)
    if not times:
        return None
    index = np.searchsorted(np.asarray(times), np.asarray(recording.times), side='right') - 1
    return np.where(index >= 0, np.asarray(values)[np.maximum(index, 0)], 0.0)


def _floors(base: dict[str, float]) -> list[float]:
    floors = []
    for joint in NODE_JOINTS:
        counts = float(base.get(f'encoder_counts_{joint}', 0) or 0)
        q = 2 * math.pi / counts if counts else 0.0
        sigma = float(base.get(f'position_noise_{joint}', 0.0) or 0.0)
        floors.append(max(math.sqrt(sigma ** 2 + q ** 2 / 12.0), IDEAL_FLOOR))
    return floors


def half_widths(fitted: Sequence[FitParameter], estimates: Sequence[Estimate]) -> list[float]:
    """Each estimate's ±2σ half-width in the fit's scaled coordinates (inf: none)."""
    out = []
    for p, e in zip(fitted, estimates, strict=True):
        try:
            out.append(abs(p.to_x(e.high) - p.to_x(e.low)) / 2.0)
        except (ValueError, ZeroDivisionError, OverflowError):
            out.append(math.inf)
    return [w if math.isfinite(w) else math.inf for w in out]


def judged(stats: Statistics, analysis: Analysis) -> Statistics:
    """``stats`` with no parameter "determined" where the model does not explain the
    data, or where a parameter moves with the part of the recording: an interval then
    holds only if the model were right."""
    moving = dict(analysis.drifting)
    estimates = []
    for e in stats.estimates:
        why = e.undetermined
        if not why and e.name in moving:
            why = (f'it moves with the part of the recording fitted ({moving[e.name]:.3g}× '
                   'its interval): it takes up what the model lacks')
        elif not why and not analysis.explains:
            why = ('the model does not explain the data (see the residual analysis): the '
                   'interval holds only for a right model')
        estimates.append(replace(e, undetermined=why))
    return replace(stats, estimates=tuple(estimates))


def drifting(fitted: Sequence[FitParameter], jacobian: np.ndarray | None,
             residual: np.ndarray, half_widths: Sequence[float]
             ) -> tuple[tuple[str, float], ...]:
    """The parameters whose one-step fits to each half of the residual differ by more
    than their ±2σ half-width (scaled coordinates), with that ratio."""
    if jacobian is None or not len(residual):
        return ()
    m = len(residual) // 2
    steps = []
    for part in (slice(0, m), slice(m, None)):
        j, r = jacobian[part], residual[part]
        step, *_ = np.linalg.lstsq(j, -r, rcond=1e-10)
        steps.append(step)
    out = []
    for k, p in enumerate(fitted):
        width = float(half_widths[k])
        change = abs(float(steps[0][k] - steps[1][k]))
        if math.isfinite(width) and width > 0 and change > DRIFT * width:
            out.append((p.name, change / width))
    return tuple(out)


def analyse(comparisons: Sequence[Comparison], base: dict[str, float],
            settle: float = 0.0, drift: tuple[tuple[str, float], ...] = ()) -> Analysis:
    """The analysis of the fit recordings' residuals after the fit (module docstring)."""
    floors = _floors(base)
    found = []
    lags = range(1, LAGS + 1)
    both = range(-LAGS, LAGS + 1)
    for c in comparisons:
        if c.role != 'fit' or c.after is None:
            continue
        t = (np.asarray(c.recording.times) - c.recording.origin) * 1e-9
        use = t >= settle
        u = command_series(c)
        for j, joint in enumerate(NODE_JOINTS):
            e = (c.measured[use, j] - c.after[use, j])
            e = e - e.mean()
            n = len(e)
            if n < 2 * LAGS + 2:
                continue
            band = BAND / math.sqrt(n)
            auto = _correlation(e, e, lags)
            cross = math.nan if u is None else float(np.mean(
                np.abs(_correlation(e, u[use], both)) > band))
            tenth = max(1, n // 10)
            energy = np.convolve(e ** 2, np.ones(tenth), 'valid')
            k = int(np.argmax(energy))
            tt = t[use]
            found.append(JointResidual(
                c.recording.path, joint, float(np.sqrt(np.mean(e ** 2))), floors[j],
                float(np.ptp(c.measured[use, j])) or 1e-300,
                (float(tt[k]), float(tt[min(len(tt) - 1, k + tenth - 1)])),
                float(np.mean(np.abs(auto) > band)), cross))
    return Analysis(tuple(found), drift)


__all__ = ['BAND', 'FLOOR_FACTOR', 'IDEAL_FLOOR', 'LAGS', 'Analysis', 'JointResidual',
           'analyse', 'command_series', 'drifting', 'half_widths', 'judged', 'verdict_lines']
