"""What a closed-loop run did, in a few numbers: :func:`run_metrics` of a
:class:`~screwgear_ros.inprocess.simulation.Run` (``run_scenario`` prints them, sweeps keep them).

* **max |TE|**: the largest |transmission error| of the active path, m.
* **tracking** (with a setpoint: t → target angle of one joint, t from the run's start):
  the RMS of target − angle over every sample, rad.
* **steps** (the setpoint's jumps, and the first target from where the run starts): per
  step, the overshoot past the new target in the step's direction (rad, and % of the
  step), and the settling time: from the step until the angle stays within
  ``SETTLING_BAND`` × |step| of the target up to the next step (None: not settled).
* **reversals** (a change of the commanded direction): the lost motion of each, the
  change of pinion 1's mesh deflection δ1 over r2 (rad at the table) between its
  settled values before and after the reversal (each the mean over the last quarter of
  the samples of its interval, between reversals): how far the table moves against
  pinion 1 when the drive reverses: the gap crossed (2b/r2 with backlash b and nothing
  to hold the other flank) plus the change of the mesh's elastic deflection under the
  changed force (the static transmission error's ripple is not in δ).
* **peak mesh forces** |F1|, |F3|, N; the **fault**, if the model diverged.
* **user metrics**: ``name: module:callable`` of a scenario, each
  ``callable(run, setpoint) -> float`` (:class:`UserMetric`).

:data:`METRIC_DOCS` names every column of :meth:`Metrics.as_dict` with its meaning (what
sweeps keep, docs/scenarios.md lists them).
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from ..errors import ScrewgearError

#: A step has settled once |target − angle| stays within this fraction of the step.
SETTLING_BAND = 0.02

#: Every column of :meth:`Metrics.as_dict`: its meaning (docs/scenarios.md lists them).
METRIC_DOCS = {
    'max_abs_te_m': 'largest |transmission error| of the active path over the run, m',
    'rms_tracking_error_rad': 'RMS of setpoint − angle of the setpoint\'s joint over every '
                              'sample, rad (NaN: no setpoint)',
    'max_overshoot_rad': 'largest overshoot past a step\'s new target, in the step\'s '
                         'direction, rad (NaN: no step)',
    'max_overshoot_percent': 'the same as a percentage of that step\'s size',
    'max_settling_time_s': 'longest time from a step until the angle stays within the '
                           'settling band up to the next step, s; inf: a step never settled',
    'reversals': 'number of changes of the commanded drive direction',
    'max_lost_motion_rad': 'largest lost motion at a reversal (change of pinion 1\'s mesh '
                           'deflection over the table radius), rad at the table',
    'peak_mesh_force_1_n': 'largest |F1|, the force of mesh 1, N',
    'peak_mesh_force_3_n': 'largest |F3|, the force of mesh 3, N',
    'rejected': 'number of commands the session refused',
    'faulted': '1 if the model diverged, else 0',
}


class BandUnit(StrEnum):
    """How a settling band is given: a fraction of the step, or absolute."""

    FRACTION = 'fraction'        # of |step|
    RAD = 'rad'                  # of the joint's angle
    COUNTS = 'counts'            # of the joint's encoder


@dataclass(frozen=True)
class SettlingBand:
    """The band a step settles into: ``value`` in ``unit`` (:class:`BandUnit`).

    Examples
    --------
    >>> SettlingBand(2, 'counts').width(0.1, 2 ** 26) == 2 * 2 * math.pi / 2 ** 26
    True
    >>> SettlingBand(0.02).describe()
    'band ±2 % of the step'
    """

    value: float = SETTLING_BAND
    unit: BandUnit = BandUnit.FRACTION

    def __post_init__(self) -> None:
        object.__setattr__(self, 'unit', BandUnit(self.unit))
        if isinstance(self.value, bool) or not isinstance(self.value, numbers.Real) \
                or not (math.isfinite(self.value) and self.value > 0.0):
            raise ValueError(f'a settling band is a finite number > 0 of {self.unit.value}, '
                             f'not {self.value!r}')

    def width(self, size: float, counts: int) -> float:
        """The band's half-width in rad for a step of ``size`` rad, on a joint whose
        encoder has ``counts`` per revolution (ValueError: counts needs an encoder)."""
        if self.unit is BandUnit.FRACTION:
            return self.value * abs(size)
        if self.unit is BandUnit.RAD:
            return float(self.value)
        if counts <= 0:
            raise ValueError('a settling band in encoder counts needs the joint\'s encoder: '
                             'its encoder_counts is 0 (an ideal sensor); give the band in rad')
        return self.value * 2.0 * math.pi / counts

    def describe(self) -> str:
        if self.unit is BandUnit.FRACTION:
            return f'band ±{100 * self.value:.3g} % of the step'
        return f'band ±{self.value:.6g} {self.unit.value}'


#: The default settling band: ±SETTLING_BAND of the step.
DEFAULT_BAND = SettlingBand()


@dataclass(frozen=True)
class UserMetric:
    """A metric of the user's: ``name`` (a column of :meth:`Metrics.as_dict`) and
    ``function(run, setpoint) -> float`` (``setpoint``: the scenario's profile or None)."""

    name: str
    function: Callable[[Any, Any], float]
    use: str = ''                 # module:callable, for messages

    def __call__(self, run: Any, setpoint: Any) -> float:
        try:
            value = self.function(run, setpoint)
        except Exception as exc:  # noqa: BLE001 - the user's code: named, not shown raw
            raise MetricFailed(f'metric {self.name} ({self.use}) raised '
                               f'{type(exc).__name__}: {exc}') from None
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise MetricFailed(f'metric {self.name} ({self.use}) returned {value!r:.60} '
                               f'({type(value).__name__}): a metric returns a number '
                               '(float; NaN where it does not apply)')
        return float(value)


class MetricFailed(ScrewgearError, ValueError):
    """A user metric that raised or returned no number; the message names it."""


@dataclass(frozen=True)
class StepResponse:
    time: float               # s: when the target jumped
    size: float               # rad: new target − old
    overshoot: float          # rad past the new target, in the step's direction (>= 0)
    settling_time: float | None   # s after the step; None: not settled before the next


@dataclass(frozen=True)
class Reversal:
    time: float               # s: the first step under the new direction
    direction: int            # the new direction, ±1
    lost_motion: float        # rad at the table (>= 0)


@dataclass(frozen=True)
class Metrics:
    """A run's metrics (module docstring). :meth:`as_dict` flattens them for tables.

    Examples
    --------
    >>> from screwgear_ros import Simulation, run_metrics
    >>> run = Simulation().run(None, 0.01)
    >>> run_metrics(run).max_abs_te >= 0.0
    True
    """

    max_abs_te: float                     # m
    rms_tracking_error: float | None      # rad; None without a setpoint
    steps: tuple[StepResponse, ...]
    reversals: tuple[Reversal, ...]
    peak_mesh_force: tuple[float, float]  # N: max |F1|, max |F3|
    fault: str | None
    rejected: int                         # commands the session refused
    band: SettlingBand = DEFAULT_BAND     # the steps' settling band
    user: tuple[tuple[str, float], ...] = ()   # user metrics, by name

    @property
    def max_overshoot(self) -> float | None:
        return max((s.overshoot for s in self.steps), default=None)

    @property
    def max_settling_time(self) -> float | None:
        """The longest settling time; inf if a step never settled; None: no step."""
        if not self.steps:
            return None
        return max(math.inf if s.settling_time is None else s.settling_time
                   for s in self.steps)

    @property
    def max_lost_motion(self) -> float | None:
        return max((r.lost_motion for r in self.reversals), default=None)

    def as_dict(self) -> dict[str, float]:
        """Flat name → float (NaN where a metric does not apply), units in the names.

        Returns
        -------
        dict of str to float
            One column per metric, as sweeps write them.
        """
        def number(value: float | None) -> float:
            return math.nan if value is None else float(value)

        overshoot_pct = max((100.0 * s.overshoot / abs(s.size) for s in self.steps),
                            default=None)
        return {
            'max_abs_te_m': self.max_abs_te,
            'rms_tracking_error_rad': number(self.rms_tracking_error),
            'max_overshoot_rad': number(self.max_overshoot),
            'max_overshoot_percent': number(overshoot_pct),
            'max_settling_time_s': number(self.max_settling_time),
            'reversals': float(len(self.reversals)),
            'max_lost_motion_rad': number(self.max_lost_motion),
            'peak_mesh_force_1_n': self.peak_mesh_force[0],
            'peak_mesh_force_3_n': self.peak_mesh_force[1],
            'rejected': float(self.rejected),
            'faulted': float(self.fault is not None),
            **dict(self.user),
        }

    def details(self) -> dict[str, Any]:
        """Every field, nested records included.

        Returns
        -------
        dict
            ``dataclasses.asdict`` of the metrics.
        """
        return asdict(self)


def run_metrics(run: Any, setpoint: Callable[[float], float] | None = None,
                joint: int | str = 'table',
                jumps: list[tuple[float, float, float]] | None = None,
                band: SettlingBand = DEFAULT_BAND,
                user: Sequence[UserMetric] = ()) -> Metrics:
    """The metrics of a run: transmission error, tracking, steps, reversals, mesh forces.

    Parameters
    ----------
    run : Run
        A :class:`~screwgear_ros.inprocess.samples.Run` (or anything with its columns).
    setpoint : callable, optional
        t (s from the run's start) → target angle (rad) of ``joint``.
    joint : int or str
        The joint the setpoint is for: a joint_states name or index.
    jumps : list of (float, float, float), optional
        The setpoint's steps as (time, before, after); default: the setpoint's own
        ``steps(duration)`` if it has them, else none.
    band : SettlingBand
        The band a step settles into (default ±2 % of the step).
    user : sequence of UserMetric
        Metrics of the user's, each called with the run and ``setpoint``.

    Returns
    -------
    Metrics
        Computed on the exact state (``run.true_position``).

    Raises
    ------
    ValueError
        ``joint`` is not a joint of the run, ``setpoint`` is a profile whose
        ``check_tick`` refuses the run's tick (a square period under two ticks), a band
        in counts on a joint without an encoder, or a user metric that fails
        (:class:`MetricFailed`).

    Examples
    --------
    >>> from screwgear_ros import Simulation, run_metrics
    >>> run = Simulation().run(None, 0.01)
    >>> m = run_metrics(run, setpoint=lambda t: 0.0)
    >>> m.rms_tracking_error is not None
    True
    """
    if isinstance(joint, str):
        names = list(run.settings.joint_names)
        if joint not in names:
            raise ValueError(f'joint {joint!r} is not one of {names}')
        joint = names.index(joint)
    check_tick = getattr(setpoint, 'check_tick', None)
    if check_tick is not None:       # a profile faster than the ticks: bounded, refused
        check_tick(run.settings.steps_per_publish * run.settings.dt)
    t = run.time - run.time[0]
    angle = run.true_position[:, joint]
    force = np.abs(run.mesh_force)
    peak = (float(force[:, 0].max()), float(force[:, 1].max())) if len(run) else (0.0, 0.0)
    rms = None
    steps: list[StepResponse] = []
    if setpoint is not None and len(run):
        target = np.array([setpoint(float(x)) for x in t])
        rms = float(np.sqrt(np.mean((target - angle) ** 2)))
        if jumps is None:
            own = getattr(setpoint, 'steps', None)
            jumps = own(float(t[-1])) if own is not None else []
        start = (0.0, float(angle[0]), float(target[0]))
        from ..params.sensors import JOINTS
        # only a band in counts reads the encoder: a run without settings (a bag's
        # columns) has its fraction or rad band
        counts = (int(getattr(run.settings, f'encoder_counts_{JOINTS[joint]}', 0))
                  if band.unit is BandUnit.COUNTS else 0)
        steps = _steps(t, angle, [start, *jumps], band, counts)
    values = tuple((m.name, m(run, setpoint)) for m in user)
    return Metrics(float(np.max(np.abs(run.transmission_error))) if len(run) else 0.0,
                   rms, tuple(steps), tuple(_reversals(run, t)), peak, run.fault,
                   len(getattr(run, 'rejected', ())), band, values)


def _steps(t: np.ndarray, angle: np.ndarray, jumps: list[tuple[float, float, float]],
           band: SettlingBand, counts: int) -> list[StepResponse]:
    out = []
    for k, (t0, before, after) in enumerate(jumps):
        size = after - before
        if size == 0.0:
            continue
        end = jumps[k + 1][0] if k + 1 < len(jumps) else math.inf
        window = (t >= t0) & (t < end)
        if not window.any():
            continue
        seen, times = angle[window], t[window]
        overshoot = max(0.0, float(np.max(np.sign(size) * (seen - after))))
        outside = np.flatnonzero(np.abs(seen - after) > band.width(size, counts))
        if not len(outside):
            settling: float | None = 0.0
        elif outside[-1] + 1 < len(seen):
            settling = float(times[outside[-1] + 1] - t0)
        else:
            settling = None
        out.append(StepResponse(float(t0), float(size), overshoot, settling))
    return out


def _reversals(run: Any, t: np.ndarray) -> list[Reversal]:
    direction = run.direction
    at = np.flatnonzero(direction[1:] != direction[:-1]) + 1
    if not len(at):
        return []
    # lost motion at the table, rad: pinion 1's mesh deflection over the table radius
    lag = run.delta[:, 0] / run.params.radius_table
    bounds = [0, *at.tolist(), len(direction)]
    settled = [_settled(lag[a:b]) for a, b in itertools.pairwise(bounds)]
    return [Reversal(float(t[i - 1]), int(direction[i]), abs(settled[k + 1] - settled[k]))
            for k, i in enumerate(at)]


def _settled(values: np.ndarray) -> float:
    """The mean over the last quarter of an interval (its settled value)."""
    return float(np.mean(values[3 * len(values) // 4:])) if len(values) else math.nan


def format_metrics(m: Metrics, details: int = 5) -> str:
    """A few lines for a person; ``details`` steps and reversals listed one by one."""
    lines = [f'max |TE|                {m.max_abs_te * 1e6:12.3f} µm']
    if m.rms_tracking_error is not None:
        lines.append(f'RMS tracking error      {m.rms_tracking_error * 1e3:12.5f} mrad')
    for s in m.steps[:details]:
        settle = ('not settled' if s.settling_time is None
                  else f'settles in {s.settling_time:.4f} s')
        lines.append(f'step at {s.time:8.4f} s  {s.size * 1e3:+9.4f} mrad: overshoot '
                     f'{s.overshoot * 1e3:.5f} mrad ({100 * s.overshoot / abs(s.size):.2f} %), '
                     f'{settle} ({m.band.describe()})')
    if len(m.steps) > details:
        assert m.max_overshoot is not None and m.max_settling_time is not None
        lines.append(f'... {len(m.steps) - details} more steps; worst overshoot '
                     f'{m.max_overshoot * 1e3:.5f} mrad, longest settling '
                     f'{m.max_settling_time:.4f} s')
    lines.append(f'reversals               {len(m.reversals):12d}')
    for r in m.reversals[:details]:
        lines.append(f'reversal at {r.time:8.4f} s to {r.direction:+d}: lost motion '
                     f'{r.lost_motion * 1e6:10.3f} µrad at the table')
    if len(m.reversals) > details:
        assert m.max_lost_motion is not None
        lines.append(f'... {len(m.reversals) - details} more reversals; largest lost motion '
                     f'{m.max_lost_motion * 1e6:.3f} µrad')
    lines.append(f'peak mesh force         {m.peak_mesh_force[0]:12.1f} N (mesh 1), '
                 f'{m.peak_mesh_force[1]:.1f} N (mesh 3)')
    if m.rejected:
        lines.append(f'commands refused        {m.rejected:12d}')
    for name, value in m.user:
        lines.append(f'{name:<24}{value:12.6g}')
    lines.append(f'fault                   {m.fault or "none"}')
    return '\n'.join(lines)


__all__ = [
    'DEFAULT_BAND',
    'METRIC_DOCS',
    'SETTLING_BAND',
    'BandUnit',
    'MetricFailed',
    'Metrics',
    'Reversal',
    'SettlingBand',
    'StepResponse',
    'UserMetric',
    'format_metrics',
    'run_metrics',
]
