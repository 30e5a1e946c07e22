"""The loop of a controller around the table, measured by simulation: loop gain, sensitivity,
closed-loop response, and the gain margin, the phase margin and the peak |S| read off the
measured loop gain.

One run of the node's own loop in-process (:class:`~screwgear_ros.inprocess.simulation.Simulation`
at the node's tick rate; the controller answers each observation with an effort that takes
effect at the next tick, as in lockstep). A sine d is added to the controller's effort c at
the plant input: u = c + d. Around a bias load that the controller holds (so the effort
keeps its sign), stepped sines in one run, each settled then fitted over whole periods
like the open-loop measurement (:mod:`.frequency`).

This is the sampled-data loop the controller lives in: every signal is the sequence of
values held over the ticks (c, u, d) or sampled at their ends (the outputs), and each
ratio is one of sequences, so the loop gain is the discrete one the controller sees,
with its zero-order hold and its one tick to answer:

* loop gain L = −c/u (the controller's answer to the plant's answer to u);
* sensitivity S = u/d = 1/(1 + L);
* closed-loop response of each output y/d (y sampled at the end of the tick d is held).

A sampled sinusoid is one sinusoid below the Nyquist frequency of the tick rate, so the
method holds up to it; it measures up to ``NYQUIST_FRACTION`` (0.9) of it, where a period
still spans more than two ticks and the whole-period fit of cos and sin stays well
conditioned. On the paper's table at 1 kHz that covers the mesh resonance (180–227 Hz)
and its gain margin. Checked against python-control on the linear model in the loop with
the controller discretized at the tick rate (test/unit/design/test_sampled_loop.py).

The "linear" columns put the linear plant into the same loop, discretized as the
controller sees it (:func:`~.margins.held_response`), with the controller as measured
(its answer c to the table angle sampled as the hold starts, C = −c/θ2): L = C·P,
S = 1/(1 + L), y/d = z·P·S. This is the controller's own law for one of the table angle;
a controller that reads more (the demo's PID reads the speed too) has its other paths
folded into C as the measured plant drives them.
"""

from __future__ import annotations

import inspect
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .. import interface
from ..inprocess.samples import observation_of
from ..inprocess.simulation import Observation, Simulation
from ..params.table import SimSettings, TableParams
from ..sim.events import Command, Timeline
from ..sim.session import AdvanceMode, Session, Tick
from .bode import loop_figure
from .budget import LOOP_TICK, Cost, check_cost, check_points
from .errors import MeasurementRefused, UnknownOutput, UsageError
from .frequency import INPUT_UNIT, Input, Measurement, Method, _fit, default_bias
from .linear_model import OUTPUTS
from .linearize import linearize
from .margins import Margins, held_response, margins

#: Rows of the closed-loop table besides the outputs' closed-loop responses.
LOOP, SENSITIVITY = 'loop_gain', 'sensitivity'
#: Settling before each frequency, s, and at least this many periods.
SETTLE, SETTLE_PERIODS = 0.5, 2
#: Fit window: at least this many periods and this long, s.
FIT_PERIODS, FIT_MIN_TIME = 2, 0.1
#: Highest frequency measured, as a fraction of the Nyquist frequency of the tick rate
#: (module docstring).
NYQUIST_FRACTION = 0.9
#: The name of a controller factory's first parameter (a parameter name, not an input).
FACTORY_PARAMETER = 'setpoint'
#: Bytes the run keeps per tick: the effort, the disturbance and the seven outputs.
LOOP_BYTES_PER_TICK = 8 * (2 + len(OUTPUTS))


@dataclass
class LoopMeasurement:
    """The measured loop (module docstring) as a :class:`Measurement` of the rows
    ``loop_gain``, ``sensitivity`` and each output's closed-loop response, its margins
    (gain, phase, peak |S|), measured and with the linear plant, and the controller's
    name."""

    response: Measurement
    margins: Margins
    margins_linear: Margins
    name: str = 'controller'

    def figure(self):
        """Bode plot of the loop (:func:`~.bode.loop_figure`)."""
        return loop_figure(self)

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
                 direction: int = 1, mesh: str = 'average', name: str = 'controller',
                 announce: Callable[[Cost], None] | None = None) -> LoopMeasurement:
    """Measure the loop of ``controller`` around the table (module docstring).

    Parameters
    ----------
    params, settings : TableParams, SimSettings
        The table and the simulation (its publish_rate is the controller's rate).
    controller : callable
        ``controller(observation) -> effort`` (N·m, or None to keep the last).
    outputs : sequence of str
        Outputs whose closed-loop response y/d is measured too.
    frequencies : sequence of float
        Hz, each in (0, NYQUIST_FRACTION × the Nyquist frequency of the tick rate].
    amplitude : float
        Of the sine added to the effort, N·m.
    torque, load : float, optional
        The bias: ``torque`` (default twice the amplitude) and the ``load`` the
        controller holds with it (default the one that balances that torque), applied
        from the start.
    direction : int
        +1 or −1.
    mesh : str
        The linear model's mesh (:func:`~.linearize.linearize`).
    name : str
        The controller's name, for the plot's title.
    announce : callable, optional
        Told the measurement's :class:`~.budget.Cost` before it runs.

    Returns
    -------
    LoopMeasurement

    Raises
    ------
    MeasurementRefused
        A frequency out of range, an amplitude that is no finite positive number, or a
        measurement beyond the budget (:mod:`.budget`).
    UnknownOutput
        An output name that is not one of OUTPUTS.
    """
    settings = settings or SimSettings()
    unknown = [name for name in outputs if name not in OUTPUTS]
    if unknown:
        raise UnknownOutput(f'unknown output {unknown[0]}; outputs are '
                            f'{", ".join(OUTPUTS)}')
    if not (math.isfinite(amplitude) and amplitude > 0.0):
        raise MeasurementRefused(f'amplitude must be a finite number > 0, got {amplitude!r}')
    check_points(len(frequencies))
    hz_points = np.sort(np.asarray(frequencies, dtype=float))
    simulation = Simulation.from_values({**params.as_dict(), **settings.as_dict()},
                                        command_timeout=0.0, record='')
    h = simulation.tick_period
    highest = NYQUIST_FRACTION * 0.5 / h
    if hz_points.size == 0 or not np.all(np.isfinite(hz_points)) or hz_points[0] <= 0.0 \
            or hz_points[-1] > highest:
        raise MeasurementRefused(f'closed-loop frequencies must lie in (0, {highest:g}] Hz: '
                                 f'{NYQUIST_FRACTION:g} of the Nyquist frequency of the '
                                 f'controller\'s rate ({1.0 / h:g} Hz, publish_rate)')
    bias = default_bias(params, Input.TORQUE, amplitude, torque, load, direction)
    model = linearize(params, bias[0], bias[1], direction, mesh)
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
    cost = Cost(total, total, total * h, total * LOOP_BYTES_PER_TICK, LOOP_TICK)
    check_cost(cost)
    if announce is not None:
        announce(cost)
    d = np.zeros(total + 1)
    for k, (_start, end, omega) in enumerate(plan):
        first = 0 if k == 0 else plan[k - 1][1]
        j = np.arange(first, end)                     # d[j + 1] is held over tick j + 1
        d[j + 1] = amplitude * np.cos(omega * (j + 0.5) * h)
    effort = np.zeros(total + 1)       # c answered to observation k, held over tick k + 1
    y = np.zeros((total + 1, len(OUTPUTS)))
    started = time.perf_counter()
    session = Session(simulation.params, simulation.settings)
    # the bias load from the first tick on; the second tick takes nothing; from the
    # third on, tick k + 3 takes the answer to observation k + 2 plus d[k + 1]
    bias_load = Timeline([Command(interface.Input.LOAD_TORQUE, bias[1], step=0)])
    observation = observation_of(session.last_outputs, session.plant.fault, session.measured)
    last = direction * bias[0]
    done = 0

    def answer() -> float | None:
        nonlocal last
        k = done - 2
        if k < 0:
            return None
        c = controller(observation)
        if c is not None:
            last = float(c)
        effort[k] = last
        return last + d[k + 1]

    def monitor(tick: Tick | None) -> None:
        nonlocal observation, done
        done += 1
        if tick is not None and tick.rejected:
            raise tick.rejected[0]
        observation = observation_of(session.last_outputs, session.plant.fault,
                                     session.measured)
        if observation.fault is not None:
            raise FloatingPointError(f'the model diverged: {observation.fault}')
        if done > 2:
            p, v = observation.position, observation.velocity
            y[done - 2] = (p[1], v[1], p[0], v[0], p[2], v[2], observation.transmission_error)

    session.advance(total + 2, events=bias_load, controller=answer, monitor=monitor,
                    mode=AdvanceMode.ANSWERS)
    wall = time.perf_counter() - started
    names = (LOOP, SENSITIVITY, *outputs)
    measured = np.empty((len(names), len(plan)), dtype=complex)
    linear = np.empty_like(measured)
    coherence = np.empty((len(names), len(plan)))
    exact = np.array([omega / (2.0 * math.pi) for _, _, omega in plan])
    plant = held_response(model, exact, h)[:, 0, :]
    angle = OUTPUTS.index('table_angle')
    for k, (start, end, omega) in enumerate(plan):
        held = np.arange(start + 1, end + 1)          # ticks whose held values are fitted
        # every sequence on one time base, the middle of each hold: the disturbance's
        # phasor is then the amplitude itself, and each ratio is the sampled loop's
        signals = np.column_stack([effort[held - 1], effort[held - 1] + d[held],
                                   y[held][:, rows], y[held - 1, angle]])
        phasor, coh = _fit((held - 0.5) * h, signals, omega)
        c_ph, u_ph, y_ph, angle_ph = phasor[0], phasor[1], phasor[2:-1], phasor[-1]
        loop = -c_ph / u_ph
        measured[:, k] = (loop, u_ph / amplitude, *(y_ph / amplitude))
        coherence[:, k] = (min(coh[0], coh[1]), coh[1], *coh[2:-1])
        # the controller as measured: its answer to the table angle sampled as the hold
        # starts, with the plant the controller sees (held in, sampled out)
        loop_lin = -c_ph / angle_ph * plant[angle, k]
        s_lin = 1.0 / (1.0 + loop_lin)
        ahead = np.exp(1j * omega * h)                # outputs at the end of the hold
        linear[:, k] = (loop_lin, s_lin, *(ahead * plant[rows, k] * s_lin))
    measurement = Measurement(Input.TORQUE, names, exact, measured, linear, coherence, model,
                              amplitude, Method.SINE, total * h, wall,
                              list(model.point.warnings))
    return LoopMeasurement(measurement, margins(exact, measured[0]),
                           margins(exact, linear[0]), name)


def make_controller(use: str, simulation_settings: SimSettings, target: float = 0.0
                    ) -> Callable[[Observation], float | None]:
    """The controller ``use`` names, holding the table at ``target`` rad.

    Parameters
    ----------
    use : str
        ``demo`` (the demo PID) or ``module:callable``, the module imported as
        ``python -m`` imports one: the current directory first, then the Python path.
        The callable is either a factory, told by its first parameter's name
        ``setpoint`` and called once as scenarios call it, ``factory(setpoint)`` (a
        constant setpoint ``target`` on the table), returning the controller; or the
        controller itself, ``controller(observation) -> effort`` (N·m or None), called
        every tick.
    simulation_settings : SimSettings
        The settings of the simulation the controller will run in (the demo's dt).
    target : float
        The table angle held, rad.

    Returns
    -------
    callable
        ``controller(observation) -> float | None``.

    Raises
    ------
    UsageError
        ``use`` names no importable callable, or a plain controller answers its first
        observation with a callable (a factory whose first parameter is not named
        ``setpoint``).

    Examples
    --------
    >>> from screwgear_ros.params.table import SimSettings
    >>> callable(make_controller('demo', SimSettings()))
    True
    """
    from ..inprocess.scenario import ControllerSpec, SetpointProfile, resolve_callable
    if use != 'demo' and (use.count(':') != 1 or not all(use.split(':'))):
        raise UsageError(f'--controller must be demo or module:callable, not {use!r}')
    setpoint = SetpointProfile('steps', points=((0.0, float(target)),))
    holder = Simulation(settings=simulation_settings)
    if use == 'demo':
        return ControllerSpec(use).make(holder, setpoint)
    try:
        found = resolve_callable(use, os.getcwd())
    except (ImportError, AttributeError, TypeError) as exc:
        raise UsageError(f'--controller {use}: {type(exc).__name__}: {exc} (the module is '
                         'looked for in the current directory, then on the Python '
                         'path)') from None
    if _is_factory(found):
        return found(setpoint)
    return _PlainController(use, found)


def _is_factory(found: Callable[..., object]) -> bool:
    """Whether ``found``'s first parameter is named ``setpoint`` (a factory)."""
    try:
        parameters = list(inspect.signature(found).parameters)
    except (TypeError, ValueError):       # a builtin without a signature: a controller
        return False
    return bool(parameters) and parameters[0] == FACTORY_PARAMETER


class _PlainController:
    """A controller named directly; its first answer must be an effort, not a controller
    (which would mean a factory whose first parameter is not named ``setpoint``)."""

    def __init__(self, use: str, controller: Callable[[Observation], float | None]) -> None:
        self.use, self.controller, self.checked = use, controller, False

    def __call__(self, observation: Observation) -> float | None:
        answer = self.controller(observation)
        if not self.checked:
            self.checked = True
            if callable(answer):
                raise UsageError(f'--controller {self.use} answered an observation with a '
                                 'callable: a factory is told by its first parameter\'s name, '
                                 '"setpoint"')
        return answer


__all__ = [
    'FACTORY_PARAMETER',
    'INPUT_UNIT',
    'LOOP',
    'LOOP_BYTES_PER_TICK',
    'NYQUIST_FRACTION',
    'SENSITIVITY',
    'LoopMeasurement',
    'Margins',
    'make_controller',
    'margins',
    'measure_loop',
]
