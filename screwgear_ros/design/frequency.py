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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import overload

import numpy as np

from .. import interface
from ..inprocess.simulation import Simulation
from ..params.table import SimSettings, TableParams
from ..physics.drive import DrivePiece
from ..sim.events import Command, Timeline
from ..sim.session import Tick
from .bode import TRUST, measurement_figure
from .budget import SINE_TICK, Cost, check_cost, check_points
from .errors import MeasurementFailed, MeasurementRefused, UnknownOutput
from .linear_model import OUTPUTS, LinearModel
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
#: Transient allowance: this many time constants of the slowest decaying mode.
SETTLE_TIME_CONSTANTS = 8.0
#: Bounds of the settling time, s.
SETTLE_MIN, SETTLE_MAX = 0.02, 2.0
#: Fit window: at least this many periods and this long, s (rounded up to whole periods).
FIT_PERIODS, FIT_MIN_TIME = 2, 0.02
#: Bytes a run keeps per tick and per column (inputs, outputs, fitted columns: float64),
#: and the columns it works with besides the outputs (steps, times, input, fit basis).
BYTES_PER_TICK, WORK_COLUMNS = 8, 6


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
        """A Bode plot (:func:`~.bode.measurement_figure`)."""
        return measurement_figure(self, INPUT_COLUMN[self.input], INPUT_UNIT)

    def save_figure(self, path: str | Path) -> None:
        import matplotlib.pyplot as plt
        fig = self.figure()
        try:
            fig.savefig(path, dpi=110)
        finally:
            plt.close(fig)


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


class _Inputs(Sequence[Command]):
    """A run's commands as its :class:`Timeline` reads them: ``bias`` at step 0, then
    ``values[k]`` on ``topic`` at the first step of tick k (signed by ``direction`` as
    cmd_effort's one value; 0: as it is), each made when read, so that a long run holds
    no command per tick."""

    def __init__(self, bias: Command, topic: str, direction: int, values: np.ndarray,
                 per_tick: int) -> None:
        self.bias, self.topic, self.direction = bias, topic, direction
        self.values, self.per_tick = values, per_tick

    def __len__(self) -> int:
        return len(self.values) + 1

    @overload
    def __getitem__(self, i: int) -> Command: ...
    @overload
    def __getitem__(self, i: slice) -> list[Command]: ...

    def __getitem__(self, i: int | slice) -> Command | list[Command]:
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        k = (i + len(self) if i < 0 else i) - 1
        if k < 0:
            return self.bias
        value = self.values[k]                   # IndexError past the end
        return Command(self.topic, [self.direction * value] if self.direction else value,
                       step=k * self.per_tick)


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
        per_tick = session.settings.steps_per_publish
        effort, load_torque = interface.Input.CMD_EFFORT, interface.Input.LOAD_TORQUE
        if self.input is Input.TORQUE:
            events = _Inputs(Command(load_torque, load, step=0), effort, d, values, per_tick)
        else:
            events = _Inputs(Command(effort, [d * torque], step=0), load_torque, 0, values,
                             per_tick)
        out = np.empty((len(values), len(OUTPUTS)))
        done = 0

        def sample(tick: Tick | None) -> None:
            nonlocal done
            if session.plant.fault is not None:
                raise FloatingPointError(f'the model diverged: {session.plant.fault}')
            o = session.last_outputs
            p, v = o.position, o.velocity
            out[done] = (p[1], v[1], p[0], v[0], p[2], v[2], o.transmission_error)
            done += 1

        session.advance(len(values), events=Timeline(events), monitor=sample)
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
            method: Method | str = Method.SINE, mesh: str = 'average',
            announce: Callable[[Cost], None] | None = None) -> Measurement:
    """Measure the response from ``input`` to ``outputs`` (module docstring), beside the
    linear model's with the ``mesh`` taken as :func:`linearize` takes it; ``announce`` is
    told the :class:`~.budget.Cost` before the runs start. Raises
    :class:`~.errors.MeasurementRefused` for a request beyond the bounds of
    :mod:`.budget`."""
    input, method = Input(input), Method(method)
    settings = settings or SimSettings()
    unknown = [name for name in outputs if name not in OUTPUTS]
    if unknown or not outputs:
        raise UnknownOutput(f'unknown output {unknown[0] if unknown else "(none)"}; '
                            f'outputs are {", ".join(OUTPUTS)}')
    check_points(len(frequencies))
    hz_points = np.sort(np.asarray(frequencies, dtype=float))
    bias = default_bias(params, input, amplitude, torque, load, direction)
    model = linearize(params, bias[0], bias[1], direction, mesh)
    check_request(model, input, amplitude, hz_points, settings.dt)
    settle = _settle_time(model)
    plan = None
    if method is Method.SINE:
        plan = [_sine_plan(hz, settings.dt, settle) for hz in hz_points]
        hz_points = np.array([omega / (2.0 * math.pi) for _, _, omega in plan])
        runs = [ticks for _, ticks, _ in plan]
    else:
        runs = [_chirp_ticks(hz_points, settings.dt, settle)]
    cost = Cost(sum(runs), max(runs), sum(runs) * settings.dt,
                max(runs) * BYTES_PER_TICK * (len(outputs) + len(OUTPUTS) + WORK_COLUMNS),
                SINE_TICK)
    check_cost(cost)
    if announce is not None:
        announce(cost)
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


def _chirp_ticks(frequencies: np.ndarray, h: float, settle: float) -> int:
    """The ticks of the chirp's one run (:func:`_chirp`)."""
    duration = max(10.0 / frequencies[0], 20.0 * settle)
    return round(duration / h) + math.ceil(settle / h)


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
    assert ticks + start == _chirp_ticks(frequencies, h, settle)
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
    'TRUST',
    'Input',
    'Measurement',
    'Method',
    'check_request',
    'default_bias',
    'measure',
]
