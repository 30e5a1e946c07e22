"""Compare a replayed run with the run it replays: event timing, then trajectories.

A lockstep replay (``replay_run`` into a lockstep node, the default) applies every
event at its recorded step, so the runs must be identical: :func:`exact_comparison`
says so, or names the first step and signal where they differ.

A free-running replay over DDS applies each recorded event (input command, parameter
change, reset) at the first tick after it arrives, so it may land a publish tick or so
away from its recorded step, and the trajectories then differ by what that timing
makes. :func:`compare_runs` does not guess a tolerance for that difference; it
explains it: the replay is ``CONSISTENT`` (not the same run: consistent with its own
events) when it started from the original's parameters,
applied every physical event of the original, in order, and nothing else, and its
outputs are, bit for bit, what the session computes from those events at the steps
they landed (an in-process replay of the new recording). The trajectory difference to
the original is then due to the measured timing alone; it is reported beside it. One
matching pass over the events and one in-process run: linear in the run's length.
"""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass, field, replace

import numpy as np

from ..bag.reader import RecordedRun, Signal
from ..sim.events import Command, Event, ParameterChange, describe
from ..sim.schedule import ros_values
from .check import sensor_mismatch, signal_names
from .replay_in_process import replay_in_process


@dataclass(frozen=True)
class EventTiming:
    """When one recorded event took effect in the original and in the replay."""

    what: str
    original_step: int
    new_step: int | None      # None: never applied in the replay

    @property
    def delay(self) -> int | None:
        return None if self.new_step is None else self.new_step - self.original_step


@dataclass(frozen=True)
class SignalDifference:
    """The largest |replay - original| of one signal at the samples both have."""

    name: str
    unit: str
    max_diff: float
    at_time: float
    scale: float = 0.0        # largest |value| of the signal in the original


@dataclass
class Comparison:
    """A free-running replay against its original (module docstring)."""

    timings: list[EventTiming]
    ticks: int                                # integration steps per publish tick
    jitter_ticks: float                       # largest |delay| in publish ticks
    samples: int                              # replay samples checked against its events
    first_difference: Difference | None     # where the replay is not what its events make
    extra: list[str] = field(default_factory=list)            # events the original lacks
    start_differences: list[str] = field(default_factory=list)  # start values that differ
    common: int = 0                           # samples at steps both runs have
    signals: list[SignalDifference] = field(default_factory=list)
    identical: bool = False                   # same values at every common sample
    #: where the replay's measured joint_states first depart from what its sensors
    #: measure of its exact state (non-ideal sensors; None: they follow it)
    sensor_mismatch: str | None = None

    @property
    def nothing_compared(self) -> str | None:
        """Why nothing was compared, or None."""
        if self.samples == 0:
            return 'the replay recorded no joint_states'
        if self.common == 0:
            return 'the replay and the original have no output sample at a common step'
        return None

    @property
    def ok(self) -> bool:
        """The replay is CONSISTENT: its outputs are what the original's events make at
        the steps they landed (not: the same run as the original)."""
        return (self.nothing_compared is None and self.first_difference is None
                and self.sensor_mismatch is None
                and not self.extra and not self.start_differences
                and all(t.new_step is not None for t in self.timings))

    def largest(self) -> SignalDifference | None:
        """The signal that differs most from the original, measured against the size of
        that signal in the original (its units differ from the others'); None when no
        sample was common."""
        if not self.signals:
            return None
        return max(self.signals, key=lambda s: s.max_diff / s.scale if s.scale > 0.0
                   else (np.inf if s.max_diff > 0.0 else 0.0))


def _physical_events(run: RecordedRun) -> list[tuple[int, Event]]:
    """Events that change the physics: commands, resets, parameter changes of TableParams
    (a settings-only change such as real_time_factor does not count)."""
    out = []
    params = run.parameters.params
    for k, (_, event) in enumerate(run.events):
        if isinstance(event, ParameterChange):
            if event.params == params:
                continue
            params = event.params
        out.append((k, event))
    return out


def _key(event: Event) -> tuple:
    """Equal for the same event content (whatever its step)."""
    if isinstance(event, Command):
        return ('command', event.topic, repr(event.value))
    if isinstance(event, ParameterChange):
        return ('parameters', repr(event.params))
    return ('reset',)


def match_events(original: RecordedRun, new: RecordedRun) -> list[EventTiming]:
    """Each physical event of ``original`` with the step the same event took in ``new``:
    the first one with its content after the last matched (one pass, indexed by content)."""
    timings, _ = _match(original, new)
    return timings


def _match(original: RecordedRun, new: RecordedRun) -> tuple[list[EventTiming], list[Event]]:
    """(timings, the physical events of ``new`` that matched nothing)."""
    candidates = [e for _, e in _physical_events(new)]
    where: dict[tuple, list[int]] = {}
    for k, event in enumerate(candidates):
        where.setdefault(_key(event), []).append(k)
    timings, used, j = [], set(), -1
    for _, event in _physical_events(original):
        assert event.step is not None      # a recorded event carries its step
        places = where.get(_key(event), [])
        i = bisect_right(places, j)
        if i < len(places):
            j = places[i]
            used.add(j)
            timings.append(EventTiming(describe(event), event.step, candidates[j].step))
        else:
            timings.append(EventTiming(describe(event), event.step, None))
    return timings, [e for k, e in enumerate(candidates) if k not in used]


#: Start values a free-running replay may differ in without changing the physics.
_NOT_PHYSICAL = ('publish_clock',)


def _start_differences(original: RecordedRun, new: RecordedRun) -> list[str]:
    a = ros_values(original.parameters.params, original.parameters.settings)
    b = ros_values(new.parameters.params, new.parameters.settings)
    return [f'{k} = {b.get(k)!r} (original {a.get(k)!r})' for k in sorted({*a, *b})
            if k not in _NOT_PHYSICAL and a.get(k) != b.get(k)]


def shift_event(run: RecordedRun, index: int, steps: int) -> RecordedRun:
    """``run`` with event ``index`` moved by ``steps`` integration steps (same outputs
    sampled). In file order an event at step s follows the outputs of step s."""
    _moved_order, moved = run.events[index]
    assert moved.step is not None      # a recorded event carries its step
    target = moved.step + steps
    out_steps = np.concatenate([run.true_joint_states.steps, run.transmission_error.steps])
    out_order = np.concatenate([run.true_joint_states.order, run.transmission_error.order])
    before = out_order[out_steps <= target]
    order = (float(before.max()) if len(before) else -1.0) + 0.5
    events = [(float(o), e) for o, e in run.events]
    events[index] = (order, replace(moved, step=target))
    events.sort(key=lambda item: (item[1].step, item[0]))
    return replace(run, events=events)


def _first_difference(steps: np.ndarray, recorded: np.ndarray, computed: np.ndarray,
                      names: list[str]) -> Difference | None:
    rows = np.flatnonzero(np.any(recorded != computed, axis=1))
    if not len(rows):
        return None
    k = int(rows[0])
    c = int(np.flatnonzero(recorded[k] != computed[k])[0])
    return Difference(int(steps[k]), names[c], float(recorded[k, c]), float(computed[k, c]))


def compare_runs(original: RecordedRun, new: RecordedRun) -> Comparison:
    """Event timing, start values, and whether ``new`` is what its events make (module
    docstring); and the difference to ``original`` at common samples. Raises BagError
    where ``new`` disagrees with its own events in kind (an event off its tick grid)."""
    ticks = original.parameters.settings.steps_per_publish
    timings, extra = _match(original, new)
    delays = [abs(t.delay) for t in timings if t.delay is not None]
    names = signal_names(original)
    labels = [name for name, _ in names]
    replayed = replay_in_process(new)
    first = _first_difference(new.true_joint_states.steps, new.true_joint_states.values,
                              replayed.joint_states, labels[:9])
    te = _first_difference(new.transmission_error.steps, new.transmission_error.values,
                           replayed.transmission_error[:, None], labels[9:])
    if te is not None and (first is None or te.step < first.step):
        first = te
    result = Comparison(timings, ticks, max(delays, default=0) / ticks, len(new.true_joint_states),
                        first, [describe(e) for e in extra],
                        _start_differences(original, new))
    _, a_js, b_js = np.intersect1d(original.true_joint_states.steps, new.true_joint_states.steps,
                                   return_indices=True)
    _, a_te, b_te = np.intersect1d(original.transmission_error.steps,
                                   new.transmission_error.steps, return_indices=True)
    result.common = len(a_js)
    columns = [(original.true_joint_states, new.true_joint_states, a_js, b_js, c, names[c])
               for c in range(9)]
    columns.append((original.transmission_error, new.transmission_error, a_te, b_te, 0,
                    names[9]))
    same = True
    for a, b, rows_a, rows_b, c, (name, unit) in columns:
        if not len(rows_a):
            continue
        diff = np.abs(b.values[rows_b, c] - a.values[rows_a, c])
        worst = int(np.argmax(diff))
        same = same and not np.any(diff)
        result.signals.append(SignalDifference(name, unit, float(diff[worst]),
                                               float(a.steps[rows_a[worst]] * original.dt),
                                               float(np.max(np.abs(a.values[rows_a, c])))))
    result.identical = same and result.common > 0
    result.sensor_mismatch = sensor_mismatch(new)[1]
    return result


#: Why a free-running replay is judged CONSISTENT, never IDENTICAL.
WHY_NOT_THE_SAME = ('a free-running replay cannot reproduce the original: each event takes '
                    'effect at the tick the wall clock brings it, often a tick or more off '
                    'its recorded step, and the table answers a moved event with another '
                    'trajectory (replay in lockstep, the default, for the same run)')


def format_comparison(c: Comparison) -> str:
    """What ``replay_run --compare`` prints for a free-running replay: the verdict is
    CONSISTENT (its outputs are what its events make) or INCONSISTENT, with the timing
    and signal differences to the original beside it."""
    lines = [('free-running replay vs original (events land where the wall clock put them; '
             'the replay is consistent when its outputs are exactly what the original\'s '
             'events make at the steps they landed): event timing (integration steps; one '
             f'publish tick = {c.ticks} steps)')]
    for t in c.timings:
        lines.append(f'  {t.what:<32} recorded step {t.original_step:>9}  replayed '
                     + ('never' if t.new_step is None else
                        f'{t.new_step:>9}  delay {t.delay:+d}'))
    lines.append(f'  largest timing difference: {c.jitter_ticks:g} publish ticks')
    for what in c.extra:
        lines.append(f'  not in the original: {what}')
    for what in c.start_differences:
        lines.append(f'  start value differs: {what}')
    lines.append(f'the replay\'s {c.samples} samples against its events at the steps they '
                 'landed: ' + ('identical' if c.first_difference is None else
                              f'first difference at step {c.first_difference.step}: '
                              f'{c.first_difference.signal} {c.first_difference.original!r} '
                              f'recorded, {c.first_difference.replayed!r} computed'))
    if c.sensor_mismatch is not None:
        lines.append(f'the replay\'s measured joint_states: {c.sensor_mismatch}')
    lines.append(f'difference to the original at {c.common} common samples (what the timing '
                 'above makes):')
    lines.append(f'  {"signal":<26}{"unit":<7}{"max diff":>12}{"at t [s]":>11}')
    for s in c.signals:
        lines.append(f'  {s.name:<26}{s.unit:<7}{s.max_diff:>12.3e}{s.at_time:>11.4f}')
    if c.identical:
        lines.append('  the replay reproduces the original bit for bit')
    if c.nothing_compared is not None:
        lines.append(f'  RESULT: NOTHING COMPARED: {c.nothing_compared}')
        return '\n'.join(lines)
    largest = c.largest()
    beside = f'timing differs by up to {c.jitter_ticks:g} publish ticks'
    if largest is not None:
        beside += (f', largest signal difference {largest.name} {largest.max_diff:.3g} '
                   f'{largest.unit} at t = {largest.at_time:.4f} s')
    lines.append(f'  RESULT: {"CONSISTENT" if c.ok else "INCONSISTENT"} ({beside})')
    if not c.identical:
        lines.append(f'  {WHY_NOT_THE_SAME}')
    return '\n'.join(lines)


@dataclass(frozen=True)
class Difference:
    """Where a replay first departs from the original."""

    step: int
    signal: str
    original: float
    replayed: float


@dataclass
class ExactComparison:
    """A lockstep replay against its original: event steps and every output sample."""

    timings: list[EventTiming]
    samples: int                          # output samples compared
    first_difference: Difference | None   # None: identical at every sample
    missing: str | None = None            # what the replay lacks (it stopped early)
    #: samples compared after the original's start step (its start sample is the
    #: parameters' equilibrium, which any run starts from: it shows no run)
    run_samples: int | None = None
    start_step: int = 0

    @property
    def nothing_compared(self) -> str | None:
        """Why nothing was compared, or None."""
        if self.samples == 0:
            return 'neither run has an output sample to compare'
        if self.run_samples == 0:
            return (f'the original holds no output sample after the start of its run (step '
                    f'{self.start_step}): a replay of no run is not identical to anything')
        return None

    @property
    def ok(self) -> bool:
        return (self.missing is None and self.first_difference is None
                and self.nothing_compared is None and all(t.delay == 0 for t in self.timings))


def exact_comparison(original: RecordedRun, new: RecordedRun) -> ExactComparison:
    """Every physical event at its recorded step, and every output sample of
    ``original`` equal bit for bit in ``new`` (which may run on past its end). A
    comparison of no sample says so (:attr:`ExactComparison.nothing_compared`) and is
    never :attr:`~ExactComparison.ok`."""
    timings = match_events(original, new)
    names = [name for name, _ in signal_names(original)]
    columns = [(original.true_joint_states, new.true_joint_states, names[:9]),
               (original.transmission_error, new.transmission_error, names[9:])]
    if original.measured is not None:       # and what the sensors measured of them
        columns.append((original.measured, new.measured or Signal(
            np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, 9))),
            [f'measured {name}' for name in names[:9]]))
    first: Difference | None = None
    missing = None
    samples = run_samples = 0
    start = original.parameters.start_step
    for a, b, signal in columns:
        n = len(a)
        if len(b) < n:
            missing = (f'the replay has {len(b)} samples of {signal[0]}, the original {n}')
            n = len(b)
        samples += n
        run_samples += int(np.count_nonzero(a.steps[:n] > start))
        steps_differ = np.nonzero(a.steps[:n] != b.steps[:n])[0]
        values_differ = np.nonzero(np.any(a.values[:n] != b.values[:n], axis=1))[0]
        for k in sorted({*steps_differ[:1], *values_differ[:1]})[:1]:
            if a.steps[k] != b.steps[k]:
                found = Difference(int(a.steps[k]), 'sample step', float(a.steps[k]),
                                   float(b.steps[k]))
            else:
                c = int(np.nonzero(a.values[k] != b.values[k])[0][0])
                found = Difference(int(a.steps[k]), signal[c], float(a.values[k, c]),
                                   float(b.values[k, c]))
            if first is None or found.step < first.step:
                first = found
    return ExactComparison(timings, samples, first, missing, run_samples, start)


def format_exact(c: ExactComparison) -> str:
    """What ``replay_run --compare`` prints for a lockstep replay."""
    late = [t for t in c.timings if t.delay != 0]
    lines = [('replay vs original (lockstep: every event must take effect at its recorded '
             'step and every output must be identical)'),
             f'  events: {len(c.timings) - len(late)} of {len(c.timings)} at their recorded step']
    for t in late:
        lines.append(f'    {t.what}: recorded step {t.original_step}, replayed '
                     + ('never' if t.new_step is None else f'at step {t.new_step}'))
    lines.append(f'  outputs: {c.samples} samples compared')
    if c.missing:
        lines.append(f'    {c.missing}')
    if c.first_difference is not None:
        d = c.first_difference
        lines.append(f'    first difference at step {d.step}: {d.signal} {d.original!r} in the '
                     f'original, {d.replayed!r} in the replay')
    lines.append('  RESULT: ' + (f'NOTHING COMPARED: {c.nothing_compared}'
                                 if c.nothing_compared is not None else
                                 'IDENTICAL: the replay reproduces the original bit for bit'
                                 if c.ok else 'DIFFERENT'))
    return '\n'.join(lines)


__all__ = [
    'WHY_NOT_THE_SAME',
    'Comparison',
    'Difference',
    'EventTiming',
    'ExactComparison',
    'SignalDifference',
    'compare_runs',
    'exact_comparison',
    'format_comparison',
    'format_exact',
    'match_events',
    'shift_event',
]
