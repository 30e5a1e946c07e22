"""The loop of a controller around the table, measured by simulation: loop gain, sensitivity,
closed-loop response, and the gain and phase margins read off the measured loop gain.

One run of the node's own loop in-process (:class:`~screwgear_ros.inprocess.simulation.Simulation`
at the node's tick rate; the controller answers each observation with an effort that takes
effect at the next tick, as in lockstep). A sine d is added to the controller's effort c at
the plant input: u = c + d. Around a bias load that the controller holds (so the effort
keeps its sign), stepped sines in one run, each settled then fitted over whole periods
like the open-loop measurement (:mod:`.frequency`). With every signal taken as the value
held over each tick:

* loop gain L = −c/u (the controller's answer to the plant's answer to u, its one-tick
  delay included);
* sensitivity S = u/d = 1/(1 + L);
* closed-loop response of each output y/d.

The "linear" columns put the linear plant model into the same loop with the controller as
measured (its answer c to the table angle, C = −c/θ2): L = C·P, S = 1/(1 + L), y/d = P·S.
This is the controller's own law for one of the table angle (the demo's PID); another
controller's linear columns mean that only if it reads the table angle alone.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..inprocess.simulation import Observation, Simulation
from ..params.table import SimSettings, TableParams
from .errors import MeasurementRefused, UnknownOutput, UsageError
from .frequency import INPUT_UNIT, Input, Measurement, Method, _fit, default_bias
from .linear_model import OUTPUTS
from .linearize import linearize

#: Rows of the closed-loop table besides the outputs' closed-loop responses.
LOOP, SENSITIVITY = 'loop_gain', 'sensitivity'
#: Settling before each frequency, s, and at least this many periods.
SETTLE, SETTLE_PERIODS = 0.5, 2
#: Fit window: at least this many periods and this long, s.
FIT_PERIODS, FIT_MIN_TIME = 2, 0.1


@dataclass(frozen=True)
class Margins:
    """Gain margin (factor, at the phase crossover) and phase margin (degrees, at the gain
    crossover) of a loop gain; None where the range holds no crossover."""

    gain: float | None
    gain_at_hz: float | None
    phase: float | None
    phase_at_hz: float | None

    def describe(self) -> str:
        phase = (f'phase margin {self.phase:.1f}° at {self.phase_at_hz:.3g} Hz'
                 if self.phase is not None else 'no gain crossover in the range')
        gain = (f'gain margin {self.gain:.3g} ({20 * math.log10(self.gain):.1f} dB) at '
                f'{self.gain_at_hz:.4g} Hz' if self.gain is not None
                else 'no phase crossover (−180°) in the range')
        return f'{phase}; {gain}'


def margins(frequency: np.ndarray, loop: np.ndarray) -> Margins:
    """Margins of a loop gain sampled at ``frequency`` (Hz, rising): crossings located by
    linear interpolation in log frequency, of log|L| and of the phase unwrapped from the
    lowest frequency into (−360°, 0°]."""
    logf = np.log(frequency)
    mag = np.log(np.abs(loop))
    phase = np.degrees(np.unwrap(np.angle(loop)))
    phase -= 360.0 * np.ceil(phase[0] / 360.0)          # the first one in (−360, 0]
    pm = pm_hz = gm = gm_hz = None
    for k in range(len(frequency) - 1):
        if pm is None and mag[k] >= 0.0 > mag[k + 1]:
            s = mag[k] / (mag[k] - mag[k + 1])
            pm_hz = float(np.exp(logf[k] + s * (logf[k + 1] - logf[k])))
            pm = float(180.0 + phase[k] + s * (phase[k + 1] - phase[k]))
        if gm is None and (phase[k] + 180.0) * (phase[k + 1] + 180.0) <= 0.0 \
                and phase[k] != phase[k + 1]:
            s = (phase[k] + 180.0) / (phase[k] - phase[k + 1])
            gm_hz = float(np.exp(logf[k] + s * (logf[k + 1] - logf[k])))
            gm = float(1.0 / np.exp(mag[k] + s * (mag[k + 1] - mag[k])))
    return Margins(gm, gm_hz, pm, pm_hz)


@dataclass
class LoopMeasurement:
    """The measured loop (module docstring) as a :class:`Measurement` of the rows
    ``loop_gain``, ``sensitivity`` and each output's closed-loop response, and its margins."""

    response: Measurement
    margins: Margins
    margins_linear: Margins

    def figure(self):
        """Bode plot of the loop gain (margins marked) and the sensitivity's magnitude,
        measured (markers) and with the linear plant (lines through the same points)."""
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
        r = self.response
        f = r.frequency
        fig, axes = plt.subplots(3, 1, figsize=(7.5, 9.0), sharex=True)
        mag, ph, sens = axes
        for values, style, label in ((r.linear, {'color': 'C0', 'ls': '-'}, 'linear plant'),
                                     (r.measured, {'color': 'C3', 'ls': 'none', 'marker': 'o',
                                                       'ms': 4}, 'measured')):
            mag.loglog(f, np.abs(values[0]), label=label, **style)
            phase = np.degrees(np.unwrap(np.angle(values[0])))
            ph.semilogx(f, phase - 360.0 * np.ceil(phase[0] / 360.0), **style)
            sens.loglog(f, np.abs(values[1]), **style)
        mag.axhline(1.0, color='0.5', lw=0.8)
        ph.axhline(-180.0, color='0.5', lw=0.8)
        sens.axhline(1.0, color='0.5', lw=0.8)
        m = self.margins
        if m.phase is not None:
            for ax in axes:
                ax.axvline(m.phase_at_hz, color='C2', ls='--', lw=0.9)
            ph.annotate(f'phase margin {m.phase:.1f}°', (m.phase_at_hz, -180.0 + m.phase),
                        fontsize=8, color='C2')
        if m.gain is not None:
            for ax in axes:
                ax.axvline(m.gain_at_hz, color='C4', ls='--', lw=0.9)
            mag.annotate(f'gain margin {20 * math.log10(m.gain):.1f} dB',
                         (m.gain_at_hz, 1.0 / m.gain), fontsize=8, color='C4')
        mag.set(ylabel='|L|', title='loop gain L = −c/u')
        ph.set(ylabel='∠L, °')
        sens.set(ylabel='|S| = |u/d|', xlabel='frequency, Hz', title='sensitivity')
        for ax in axes:
            ax.grid(True, which='both', alpha=0.3)
        mag.legend(fontsize=8)
        fig.tight_layout()
        return fig

    def save_figure(self, path) -> None:
        import matplotlib.pyplot as plt
        fig = self.figure()
        try:
            fig.savefig(path, dpi=110)
        finally:
            plt.close(fig)


def measure_loop(params: TableParams, settings: SimSettings | None,
                 controller: Callable[[Observation], float | None], *,
                 outputs: Sequence[str] = ('table_angle',),
                 frequencies: Sequence[float] | np.ndarray = (1.0, 3.0, 10.0), amplitude: float = 10.0,
                 torque: float | None = None, load: float | None = None,
                 direction: int = 1) -> LoopMeasurement:
    """Measure the loop of ``controller`` around the table (module docstring). The bias:
    ``torque`` (default twice the amplitude) and the ``load`` the controller holds with it
    (default the one that balances that torque), applied from the start."""
    settings = settings or SimSettings()
    unknown = [name for name in outputs if name not in OUTPUTS]
    if unknown:
        raise UnknownOutput(f'unknown output {unknown[0]}; outputs are '
                            f'{", ".join(OUTPUTS)}')
    if not (math.isfinite(amplitude) and amplitude > 0.0):
        raise MeasurementRefused(f'amplitude must be a finite number > 0, got {amplitude!r}')
    hz_points = np.sort(np.asarray(frequencies, dtype=float))
    simulation = Simulation.from_values({**params.as_dict(), **settings.as_dict()},
                                        command_timeout=0.0, record='')
    h = simulation.tick_period
    if hz_points.size == 0 or hz_points[0] <= 0.0 or hz_points[-1] >= 0.05 / h:
        raise MeasurementRefused(f'closed-loop frequencies must lie in (0, {0.05 / h:g}) Hz: '
                                 f'a tenth of the Nyquist frequency of the controller\'s rate '
                                 f'({1.0 / h:g} Hz, publish_rate)')
    bias = default_bias(params, Input.TORQUE, amplitude, torque, load, direction)
    model = linearize(params, bias[0], bias[1], direction)
    rows = [OUTPUTS.index(name) for name in outputs]
    plan = []
    tick = 0
    for hz in hz_points:
        settle = max(SETTLE, SETTLE_PERIODS / hz)
        periods = max(FIT_PERIODS, math.ceil(FIT_MIN_TIME * hz))
        window = max(1, round(periods / (hz * h)))
        start = tick + math.ceil(settle / h)
        plan.append((start, start + window, 2.0 * math.pi * periods / (window * h)))
        tick = start + window
    total = tick
    d = np.zeros(total + 1)
    for k, (_start, end, omega) in enumerate(plan):
        first = 0 if k == 0 else plan[k - 1][1]
        j = np.arange(first, end)                     # d[j + 1] is held over tick j + 1
        d[j + 1] = amplitude * np.cos(omega * (j + 0.5) * h)
    effort = np.zeros(total + 1)       # c answered to observation k, held over tick k + 1
    y = np.zeros((total + 1, len(OUTPUTS)))
    started = time.perf_counter()
    observation = simulation.reset()
    simulation.step(load=bias[1])                    # the bias load from the first tick on
    observation = simulation.step()
    last = direction * bias[0]
    for k in range(total):
        c = controller(observation)
        if c is not None:
            last = float(c)
        effort[k] = last
        observation = simulation.step(effort=last + d[k + 1])
        if observation.fault is not None:
            raise FloatingPointError(f'the model diverged: {observation.fault}')
        p, v = observation.position, observation.velocity
        y[k + 1] = (p[1], v[1], p[0], v[0], p[2], v[2], observation.transmission_error)
    wall = time.perf_counter() - started
    names = (LOOP, SENSITIVITY, *outputs)
    measured = np.empty((len(names), len(plan)), dtype=complex)
    linear = np.empty_like(measured)
    coherence = np.empty((len(names), len(plan)))
    exact = np.array([omega / (2.0 * math.pi) for _, _, omega in plan])
    plant = model.response(exact)[:, 0, :]
    for k, (start, end, omega) in enumerate(plan):
        held = np.arange(start + 1, end + 1)          # ticks whose held values are fitted
        t_mid = (held - 0.5) * h
        signals = np.column_stack([effort[held - 1], effort[held - 1] + d[held],
                                   y[held][:, rows], y[held][:, OUTPUTS.index('table_angle')]])
        phasor_c, coh_c = _fit(t_mid, signals[:, :2], omega)
        c_ph, u_ph = phasor_c
        y_ph, coh_y = _fit(held * h, signals[:, 2:], omega)
        zoh = math.sin(0.5 * omega * h) / (0.5 * omega * h)
        d_ph = amplitude * zoh
        loop = -c_ph / u_ph
        measured[:, k] = (loop, u_ph / amplitude, *(y_ph[:-1] / d_ph))
        coherence[:, k] = (min(coh_c), coh_c[1], *coh_y[:-1])
        # the controller as measured: its answer to the table angle (held values against
        # samples: the same hold correction as the input)
        law = -c_ph / (y_ph[-1] * zoh)
        p_angle = plant[OUTPUTS.index('table_angle'), k]
        loop_lin = law * p_angle
        s_lin = 1.0 / (1.0 + loop_lin)
        linear[:, k] = (loop_lin, s_lin, *(plant[rows, k] * s_lin))
    measurement = Measurement(Input.TORQUE, names, exact, measured, linear, coherence, model,
                              amplitude, Method.SINE, total * h, wall,
                              list(model.point.warnings))
    return LoopMeasurement(measurement, margins(exact, measured[0]),
                           margins(exact, linear[0]))


def make_controller(use: str, simulation_settings: SimSettings, target: float = 0.0
                    ) -> Callable[[Observation], float | None]:
    """``demo`` (the demo PID holding the table at ``target`` rad) or ``module:callable``
    (a factory called as scenarios call it, ``factory(setpoint)``, with a constant
    setpoint ``target`` on the table)."""
    from ..inprocess.scenario import ControllerSpec, SetpointProfile
    if use != 'demo' and (use.count(':') != 1 or not all(use.split(':'))):
        raise UsageError(f'--controller must be demo or module:callable, not {use!r}')
    setpoint = SetpointProfile('steps', points=((0.0, float(target)),))
    holder = Simulation(settings=simulation_settings)
    return ControllerSpec(use).make(holder, setpoint)


__all__ = [
    'INPUT_UNIT',
    'LOOP',
    'SENSITIVITY',
    'LoopMeasurement',
    'Margins',
    'make_controller',
    'margins',
    'measure_loop',
]
