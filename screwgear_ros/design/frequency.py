"""The table's frequency response measured by simulation, beside its linear model's.

Each point runs the node's own loop in-process (:class:`~screwgear_ros.inprocess.simulation.
Simulation`: its session, its command validation) around the operating point of
:func:`~screwgear_ros.design.linearize.linearize`, with one tick per integration step so
the input changes at every step. Stepped sines (``Method.SINE``): for each frequency a new
run from the preload equilibrium applies the bias inputs and the sine together, lets the
transient die out (eight time constants of the slowest decaying mode of the linear model),
then fits the outputs over whole periods by least squares on cos, sin, an offset and a
linear drift. Chirp (``Method.CHIRP``): one run with an exponential sweep over the range,
the response at each frequency from the Fourier sums of the detrended output and input.

Choices where the plant is not a plain linear system:

* **Drive torque input.** The node's drive torque is a magnitude with a direction. The
  measurement applies the signed effort (cmd_effort) direction·(T + a·cos ωt) around a
  bias torque T, by default twice the amplitude so the command never reaches zero (in
  ``anti_backlash`` a sign change would move the drive to the other pinion). The drive's
  torque–speed line stays as the parameters set it: at a static operating point it lies
  above the command (the drive delivers the command: an ideal torque source there), and a
  point where the drive runs on the line is refused for the torque input (the command
  changes nothing there).
* **Rigid-body mode.** By default the bias torque works against the load that holds the
  table still (T·r2/r: a static point, both meshes loaded), and each sine starts at its
  crest (a cosine), which leaves the rigid body's speed with no mean: its angle stays
  bounded. The fit removes an offset and a linear drift anyway (detrending), so a
  steady rotation or a residual drift does not leak into the response.
* **Sampling.** The input is held for each step at the sine's value at the step's middle:
  its fundamental is the sine times sin(ωh/2)/(ωh/2), h = dt, with no delay; the response
  is divided by that factor.
* **Trust.** ``coherence`` is the fraction of the detrended output's variance the fitted
  sinusoid explains (1: the output is a sinusoid at the drive frequency; lower: harmonics,
  subharmonics, impacts or an unsettled transient, where the plant is not linear).
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

import numpy as np

from ..inprocess.simulation import Simulation
from ..params.table import SimSettings, TableParams
from ..physics.drive import DrivePiece
from ..sim.events import Command
from .errors import MeasurementFailed, MeasurementRefused, UnknownOutput
from .linear_model import OUTPUT_UNITS, OUTPUTS, LinearModel
from .linearize import linearize


class Method(StrEnum):
    SINE = 'sine'
    CHIRP = 'chirp'


class Input(StrEnum):
    TORQUE = 'torque'
    LOAD = 'load'


#: Column of B (and of the linear response) for each input.
INPUT_COLUMN = {Input.TORQUE: 0, Input.LOAD: 1}
INPUT_UNIT = 'N·m'
CSV_COLUMNS = ('frequency_hz', 'output', 'magnitude', 'phase_deg', 'magnitude_linear',
               'phase_deg_linear', 'coherence')
#: Coherence below which a measured point is drawn hollow (not to be trusted).
TRUST = 0.9
#: Transient allowance: this many time constants of the slowest decaying mode.
SETTLE_TIME_CONSTANTS = 8.0
#: Bounds of the settling time, s.
SETTLE_MIN, SETTLE_MAX = 0.02, 2.0
#: Fit window: at least this many periods and this long, s (rounded up to whole periods).
FIT_PERIODS, FIT_MIN_TIME = 2, 0.02


@dataclass
class Measurement:
    """A measured response: ``measured`` and ``linear`` are (outputs, frequencies) complex,
    output units per input unit; ``coherence`` likewise (real)."""

    input: Input
    outputs: tuple[str, ...]
    frequency: np.ndarray
    measured: np.ndarray
    linear: np.ndarray
    coherence: np.ndarray
    model: LinearModel
    amplitude: float
    method: Method
    simulated: float = 0.0              # s of simulation time
    wall: float = 0.0                   # s
    notes: list[str] = field(default_factory=list)

    def rows(self) -> list[tuple]:
        rows = []
        for k, hz in enumerate(self.frequency):
            for i, name in enumerate(self.outputs):
                m, lin = self.measured[i, k], self.linear[i, k]
                rows.append((float(hz), name, abs(m), math.degrees(np.angle(m)), abs(lin),
                             math.degrees(np.angle(lin)), float(self.coherence[i, k])))
        return rows

    def write_csv(self, path: str | Path) -> None:
        with open(path, 'w', newline='', encoding='utf-8') as stream:
            writer = csv.writer(stream)
            writer.writerow(CSV_COLUMNS)
            for row in self.rows():
                writer.writerow([f'{row[0]:.9g}', row[1], *(f'{v:.9g}' for v in row[2:])])

    def figure(self):
        """A Bode plot: magnitude and phase of each output, measured (markers; hollow where
        the coherence is below ``TRUST``) and linear (lines), the oscillating modes marked."""
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
        n = len(self.outputs)
        fig, axes = plt.subplots(2, n, figsize=(5.6 * n, 6.6), squeeze=False, sharex=True)
        fine = np.geomspace(self.frequency[0], self.frequency[-1], 600) \
            if len(self.frequency) > 1 else self.frequency
        column = INPUT_COLUMN[self.input]
        dense = self.model.response(fine)[:, column, :]
        at_points = self.model.response(self.frequency)[:, column, :]
        modes = [m for m in self.model.modes() if m.oscillating
                 and self.frequency[0] <= m.hz <= self.frequency[-1]]
        for i, name in enumerate(self.outputs):
            row = OUTPUTS.index(name)
            mag, ph = axes[0, i], axes[1, i]
            trusted = self.coherence[i] >= TRUST
            line_phase = np.degrees(np.unwrap(np.angle(dense[row])))
            # each measured phase drawn on the branch of the linear curve at its frequency
            ref = np.interp(np.log(self.frequency), np.log(fine), line_phase)
            measured_phase = ref + _deg_wrap(np.degrees(np.angle(self.measured[i]))
                                             - np.degrees(np.angle(at_points[row])))
            mag.loglog(fine, np.abs(dense[row]), color='C0', label='linear model')
            ph.semilogx(fine, line_phase, color='C0')
            for mask, style in ((trusted, {'color': 'C3'}),
                                (~trusted, {'mfc': 'none', 'mec': 'C3'})):
                if mask.any():
                    label = (f'measured ({self.method.value}, {self.amplitude:g} {INPUT_UNIT})'
                             if style.get('color') else f'measured, coherence < {TRUST:g}')
                    mag.loglog(self.frequency[mask], np.abs(self.measured[i][mask]), 'o',
                               ms=4, label=label, **style)
                    ph.semilogx(self.frequency[mask], measured_phase[mask], 'o', ms=4, **style)
            for c, mode in enumerate(modes):
                for ax in (mag, ph):
                    ax.axvline(mode.hz, color=f'C{c + 1}', lw=0.9, ls='--',
                               label=(f'{mode.hz:.1f} Hz, ζ {mode.damping:.3f}: {mode.shape}'
                                      if ax is mag else None))
            unit = OUTPUT_UNITS[row]
            mag.set_title(f'{self.input.value} → {name}', fontsize=10)
            mag.set_ylabel(f'|H|, {unit}/{INPUT_UNIT}')
            ph.set_ylabel('phase, °')
            ph.set_xlabel('frequency, Hz')
            mag.grid(True, which='both', alpha=0.3)
            ph.grid(True, which='both', alpha=0.3)
        axes[0, 0].legend(fontsize=7, loc='lower left')
        fig.tight_layout()
        return fig

    def save_figure(self, path: str | Path) -> None:
        import matplotlib.pyplot as plt
        fig = self.figure()
        try:
            fig.savefig(path, dpi=110)
        finally:
            plt.close(fig)


def _deg_wrap(angle: np.ndarray) -> np.ndarray:
    """Angles in degrees wrapped into (−180, 180]."""
    return -((-np.asarray(angle) + 180.0) % 360.0 - 180.0)


def _settle_time(model: LinearModel) -> float:
    """Eight time constants of the slowest decaying mode (the rigid body excluded)."""
    lam = model.poles()
    scale = float(np.max(np.abs(lam))) or 1.0
    decaying = -lam.real[(lam.real < -1e-9 * scale)]
    if decaying.size == 0:
        return SETTLE_MIN
    return float(np.clip(SETTLE_TIME_CONSTANTS / decaying.min(), SETTLE_MIN, SETTLE_MAX))


def default_bias(params: TableParams, input: Input, amplitude: float,
                 torque: float | None, load: float | None, direction: int
                 ) -> tuple[float, float]:
    """The operating point's torque and load (module docstring): for the torque input a
    bias torque of twice the amplitude, against the load that holds the table still."""
    if torque is None:
        torque = 2.0 * amplitude if Input(input) is Input.TORQUE else 0.0
    if load is None:
        radius = (params.radius_pinion_3 if direction < 0 and params.mode.value == 'anti_backlash'
                  else params.radius_pinion_1)
        load = direction * torque * params.radius_table / radius
    return float(torque), float(load)


def _simulation(params: TableParams, settings: SimSettings) -> Simulation:
    """The node's simulation with one tick per step and no command timeout."""
    return Simulation.from_values({**params.as_dict(), **settings.as_dict()},
                                  publish_rate=1.0 / settings.dt, command_timeout=0.0,
                                  record='')


class _Runner:
    """Runs the node's session tick by tick with an input sequence; collects outputs."""

    def __init__(self, simulation: Simulation, input: Input, direction: int,
                 bias: tuple[float, float], outputs: Sequence[str]) -> None:
        self.simulation, self.input, self.direction = simulation, input, direction
        self.bias = bias
        self.columns = [OUTPUTS.index(name) for name in outputs]

    def run(self, values: np.ndarray) -> np.ndarray:
        """A run from the preload equilibrium; values[k] is the input during tick k.
        Returns (ticks, outputs) sampled at each tick's end."""
        simulation = self.simulation
        simulation.reset()
        session = simulation.session
        torque, load = self.bias
        d = self.direction
        submit, tick = session.submit, session.tick
        if self.input is Input.TORQUE:
            submit(Command('load_torque', load))
            topic, signed = 'cmd_effort', True
        else:
            submit(Command('cmd_effort', [d * torque]))
            topic, signed = 'load_torque', False
        out = np.empty((len(values), len(OUTPUTS)))
        for k, value in enumerate(values):
            submit(Command(topic, [d * value] if signed else value))
            o = tick().outputs
            if session.plant.fault is not None:
                raise FloatingPointError(f'the model diverged: {session.plant.fault}')
            p, v = o.position, o.velocity
            out[k] = (p[1], v[1], p[0], v[0], p[2], v[2], o.transmission_error)
        rejected = sum(session.rejected.values())
        if rejected:
            raise MeasurementFailed(f'the node refused {rejected} of the input commands '
                                    '(torque beyond max_torque or load beyond its limit)')
        return out[:, self.columns]


def _fit(t: np.ndarray, y: np.ndarray, omega: float) -> tuple[np.ndarray, np.ndarray]:
    """Phasors (a − j·b for a·cos + b·sin) of each column of y at ω, and the coherence."""
    tc = t - t.mean()
    full = np.column_stack([np.cos(omega * t), np.sin(omega * t), np.ones_like(t), tc])
    coef, *_ = np.linalg.lstsq(full, y, rcond=None)
    residual = y - full @ coef
    trend = full[:, 2:]
    base, *_ = np.linalg.lstsq(trend, y, rcond=None)
    detrended = y - trend @ base
    total = np.sum(detrended ** 2, axis=0)
    with np.errstate(invalid='ignore', divide='ignore'):
        coherence = np.where(total > 0.0, 1.0 - np.sum(residual ** 2, axis=0) / total, 0.0)
    return coef[0] - 1j * coef[1], np.clip(coherence, 0.0, 1.0)


def check_request(model: LinearModel, input: Input, amplitude: float, frequencies: np.ndarray,
                  dt: float) -> None:
    """Refuse what the measurement cannot do (:class:`~.errors.MeasurementRefused` saying
    why)."""
    if not (math.isfinite(amplitude) and amplitude > 0.0):
        raise MeasurementRefused(f'amplitude must be a finite number > 0, got {amplitude!r}')
    if frequencies.size == 0 or not np.all(np.isfinite(frequencies)) or np.any(frequencies <= 0):
        raise MeasurementRefused('frequencies must be finite and > 0 Hz')
    nyquist = 0.5 / dt
    if np.max(frequencies) >= 0.1 * nyquist:
        raise MeasurementRefused(f'the highest frequency {np.max(frequencies):g} Hz must '
                                 f'stay below a tenth of the step rate\'s Nyquist frequency '
                                  f'({0.1 * nyquist:g} Hz at dt = {dt:g} s)')
    point = model.point
    if input is Input.TORQUE:
        if point.drive_piece == DrivePiece.LINE:
            raise MeasurementRefused('the drive runs on its torque–speed line at this '
                                     'operating point: a torque command changes nothing there')
        if point.torque + amplitude > model.params.max_torque:
            raise MeasurementRefused(f'bias torque {point.torque:g} + amplitude {amplitude:g} '
                                     f'N·m exceeds max_torque {model.params.max_torque:g} N·m')


def measure(params: TableParams, settings: SimSettings | None = None, *,
            input: Input | str = Input.TORQUE, outputs: Sequence[str] = ('table_angle',),
            frequencies: Sequence[float] | np.ndarray = (1.0, 10.0, 100.0), amplitude: float = 10.0,
            torque: float | None = None, load: float | None = None, direction: int = 1,
            method: Method | str = Method.SINE, mesh: str = 'average') -> Measurement:
    """Measure the response from ``input`` to ``outputs`` (module docstring), beside the
    linear model's with the ``mesh`` taken as :func:`linearize` takes it."""
    input, method = Input(input), Method(method)
    settings = settings or SimSettings()
    unknown = [name for name in outputs if name not in OUTPUTS]
    if unknown or not outputs:
        raise UnknownOutput(f'unknown output {unknown[0] if unknown else "(none)"}; '
                            f'outputs are {", ".join(OUTPUTS)}')
    hz_points = np.sort(np.asarray(frequencies, dtype=float))
    bias = default_bias(params, input, amplitude, torque, load, direction)
    model = linearize(params, bias[0], bias[1], direction, mesh)
    check_request(model, input, amplitude, hz_points, settings.dt)
    settle = _settle_time(model)
    plan = None
    if method is Method.SINE:
        plan = [_sine_plan(hz, settings.dt, settle) for hz in hz_points]
        hz_points = np.array([omega / (2.0 * math.pi) for _, _, omega in plan])
    simulation = _simulation(params, settings)
    runner = _Runner(simulation, input, direction, bias, outputs)
    column = INPUT_COLUMN[input]
    rows = [OUTPUTS.index(name) for name in outputs]
    linear = model.response(hz_points)[rows, column, :]
    h = settings.dt
    u0 = bias[0] if input is Input.TORQUE else bias[1]
    started = time.perf_counter()
    if plan is not None:
        measured, coherence, simulated = _stepped_sine(runner, plan, amplitude, u0, h)
    else:
        measured, coherence, simulated = _chirp(runner, hz_points, amplitude, u0, h, settle)
    notes = list(model.point.warnings)
    return Measurement(input, tuple(outputs), hz_points, measured, linear, coherence, model,
                       amplitude, method, simulated, time.perf_counter() - started, notes)


def _sine_plan(hz: float, h: float, settle: float) -> tuple[int, int, float]:
    """(ticks before the fit, ticks in all, ω) of one stepped-sine point: the fit covers
    whole periods, so ω is moved to the nearest frequency whose periods fill a whole number
    of steps (a relative change below one step per window)."""
    periods = max(FIT_PERIODS, math.ceil(FIT_MIN_TIME * hz))
    start = math.ceil(settle / h)
    window = max(1, round(periods / (hz * h)))
    return start, start + window, 2.0 * math.pi * periods / (window * h)


def _stepped_sine(runner: _Runner, plan: list[tuple[int, int, float]], amplitude: float,
                  u0: float, h: float) -> tuple[np.ndarray, np.ndarray, float]:
    n_out = len(runner.columns)
    measured = np.empty((n_out, len(plan)), dtype=complex)
    coherence = np.empty((n_out, len(plan)))
    simulated = 0.0
    for k, (start, ticks, omega) in enumerate(plan):
        steps = np.arange(ticks)
        values = u0 + amplitude * np.cos(omega * (steps + 0.5) * h)
        y = runner.run(values)
        t = (steps[start:] + 1) * h
        phasor, coh = _fit(t, y[start:], omega)
        zoh = math.sin(0.5 * omega * h) / (0.5 * omega * h)
        measured[:, k] = phasor / (amplitude * zoh)
        coherence[:, k] = coh
        simulated += ticks * h
    return measured, coherence, simulated


def _chirp(runner: _Runner, frequencies: np.ndarray, amplitude: float, u0: float, h: float,
           settle: float) -> tuple[np.ndarray, np.ndarray, float]:
    """One exponential sweep from a quarter of the lowest to twice the highest frequency,
    long enough for ten cycles at the lowest; at each frequency the ratio of the Fourier
    sums of the detrended output and of the input (a Hann window over the sweep). The
    coherence is the sine method's, over the sweep's passage through the frequency (±10 %):
    the fraction of the detrended output a sinusoid in the sweep's phase explains."""
    f0, f1 = 0.25 * frequencies[0], min(2.0 * frequencies[-1], 0.05 / h)
    duration = max(10.0 / frequencies[0], 20.0 * settle)
    ticks = round(duration / h)
    start = math.ceil(settle / h)
    steps = np.arange(ticks + start)
    t_mid = (steps - start + 0.5) * h               # each value holds over its step
    rate = math.log(f1 / f0) / duration
    phase = 2.0 * math.pi * f0 * (np.exp(rate * np.clip(t_mid, 0.0, None)) - 1.0) / rate
    values = u0 + amplitude * np.where(t_mid >= 0.0, np.sin(phase), 0.0)
    y = runner.run(values)[start:]
    u = values[start:] - u0
    t_u = t_mid[start:]
    t = t_u + 0.5 * h                               # outputs at the steps' ends
    trend = np.column_stack([np.ones_like(t), t - t.mean()])
    base, *_ = np.linalg.lstsq(trend, y, rcond=None)
    y = y - trend @ base
    window = np.hanning(len(t))
    n_out = y.shape[1]
    measured = np.empty((n_out, len(frequencies)), dtype=complex)
    coherence = np.zeros((n_out, len(frequencies)))
    for k, hz in enumerate(frequencies):
        omega = 2.0 * math.pi * hz
        zoh = math.sin(0.5 * omega * h) / (0.5 * omega * h)
        measured[:, k] = ((window * np.exp(-1j * omega * t)) @ y) / (
            (window * np.exp(-1j * omega * t_u)) @ u * zoh)
        centre, half = math.log(hz / f0) / rate, math.log(1.1) / rate
        mask = (t_u >= centre - half) & (t_u <= centre + half)
        if mask.sum() >= 8:
            ph = phase[start:][mask]
            basis = np.column_stack([np.cos(ph), np.sin(ph), np.ones(mask.sum()),
                                     t[mask] - t[mask].mean()])
            coef, *_ = np.linalg.lstsq(basis, y[mask], rcond=None)
            rest, *_ = np.linalg.lstsq(basis[:, 2:], y[mask], rcond=None)
            total = np.sum((y[mask] - basis[:, 2:] @ rest) ** 2, axis=0)
            left = np.sum((y[mask] - basis @ coef) ** 2, axis=0)
            with np.errstate(invalid='ignore', divide='ignore'):
                coherence[:, k] = np.clip(np.where(total > 0, 1.0 - left / total, 0.0), 0, 1)
    return measured, coherence, (ticks + start) * h


__all__ = [
    'CSV_COLUMNS',
    'INPUT_COLUMN',
    'Input',
    'Measurement',
    'Method',
    'check_request',
    'default_bias',
    'measure',
]
