"""Compare a replayed run with the run it replays: event timing, then trajectories.

A lockstep replay (``replay_run`` into a lockstep node, the default) applies every
event at its recorded step, so the runs must be identical: :func:`exact_comparison`
says so, or names the first step and signal where they differ.

A free-running replay over DDS applies each recorded event (input command, parameter change,
reset) at the first integration batch after it arrives, so it may land a publish
tick or so away from its recorded step. :func:`compare_runs` measures those delays
by matching the events of both bags in order, and judges the trajectory difference
by what such delays can explain: the tolerance of each signal is the sum over
events of the largest deviation an in-process replay of the ORIGINAL shows when
that one event alone is moved by ±J_k publish ticks (J_k = that event's measured
delay rounded up to whole ticks, at least one), times ``SAFETY``: a first-order
(superposition) bound on the effect of independent timing errors of up to J_k
ticks each. Samples within J_k ticks of event k are left out of both: there a late
step or reset differs by the whole jump it makes, whatever the accuracy; what
matters is what persists after it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..events import Command, Event, ParameterChange, describe
from .bagread import RecordedRun
from .check import (FLOOR_ABS, FLOOR_REL, NothingToCompare, SignalError, signal_error,
                    signal_names)
from .replay import replay_in_process

#: Tolerance = SAFETY × first-order bound of the measured timing jitter's effect.
SAFETY = 2.0


@dataclass(frozen=True)
class EventTiming:
    """When one recorded event took effect in the original and in the replay."""

    what: str
    original_step: int
    new_step: int | None      # None: never applied in the replay

    @property
    def delay(self) -> int | None:
        return None if self.new_step is None else self.new_step - self.original_step


@dataclass
class Comparison:
    """Timing of every event and the trajectory difference per signal."""

    timings: list[EventTiming]
    ticks: int                                # integration steps per publish tick
    jitter_ticks: float                       # largest |delay| in publish ticks
    samples: int                              # common output samples compared
    excluded: int = 0                         # samples left out near events
    signals: list[SignalError] = field(default_factory=list)
    identical: bool = False                   # same values at every common sample

    @property
    def ok(self) -> bool:
        return (all(t.new_step is not None for t in self.timings)
                and all(s.ok for s in self.signals))


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


def _same(a: Event, b: Event) -> bool:
    if type(a) is not type(b):
        return False
    if isinstance(a, Command):
        return a.topic == b.topic and a.value == b.value
    if isinstance(a, ParameterChange):
        return a.params == b.params
    return True


def match_events(original: RecordedRun, new: RecordedRun) -> list[EventTiming]:
    """Each physical event of ``original`` with the step the same event took in ``new``."""
    candidates = _physical_events(new)
    timings, j = [], 0
    for _, event in _physical_events(original):
        k = j
        while k < len(candidates) and not _same(event, candidates[k][1]):
            k += 1
        if k < len(candidates):
            timings.append(EventTiming(describe(event), event.step, candidates[k][1].step))
            j = k + 1
        else:
            timings.append(EventTiming(describe(event), event.step, None))
    return timings


def shift_event(run: RecordedRun, index: int, steps: int) -> RecordedRun:
    """``run`` with event ``index`` moved by ``steps`` integration steps (same outputs
    sampled). In file order an event at step s follows the outputs of step s."""
    moved_order, moved = run.events[index]
    target = moved.step + steps
    out_steps = np.concatenate([run.joint_states.steps, run.transmission_error.steps])
    out_order = np.concatenate([run.joint_states.order, run.transmission_error.order])
    before = out_order[out_steps <= target]
    order = (float(before.max()) if len(before) else -1.0) + 0.5
    events = [(float(o), e) for o, e in run.events]
    events[index] = (order, replace(moved, step=target))
    events.sort(key=lambda item: (item[1].step, item[0]))
    return replace(run, events=events)


def _signal_matrix(js: np.ndarray, te: np.ndarray, rows_js: np.ndarray,
                   rows_te: np.ndarray) -> list[np.ndarray]:
    return [js[rows_js, c] for c in range(9)] + [te[rows_te]]


def compare_runs(original: RecordedRun, new: RecordedRun) -> Comparison:
    """Event timing and trajectory difference of ``new`` against ``original``. Raises
    :class:`NothingToCompare` when they share no sample to judge."""
    ticks = original.parameters.settings.steps_per_publish
    timings = match_events(original, new)
    delays = [abs(t.delay) for t in timings if t.delay is not None]
    jitter = max(delays, default=0) / ticks
    _, a_js, b_js = np.intersect1d(original.joint_states.steps, new.joint_states.steps,
                                   return_indices=True)
    _, a_te, b_te = np.intersect1d(original.transmission_error.steps,
                                   new.transmission_error.steps, return_indices=True)
    events = _physical_events(original)
    budgets = [max(1, -(-abs(t.delay) // ticks) if t.delay is not None else 1) * ticks
               for t in timings]

    def away(rows: np.ndarray, steps: np.ndarray) -> np.ndarray:
        near = np.zeros(len(rows), dtype=bool)
        for (_, event), budget in zip(events, budgets):
            near |= np.abs(steps[rows] - event.step) <= budget
        return rows[~near], ~near

    a_js, keep = away(a_js, original.joint_states.steps)
    b_js = b_js[keep]
    a_te, keep = away(a_te, original.transmission_error.steps)
    b_te = b_te[keep]
    if not len(a_js):
        raise NothingToCompare(
            f'{new.path} and {original.path} share no output sample outside the timing '
            f'budget of an event ({len(original.joint_states)} samples in the original, '
            f'{len(new.joint_states)} in the replay): there is nothing to compare')
    result = Comparison(timings, ticks, jitter, len(a_js),
                        len(original.joint_states) - len(a_js))
    orig = _signal_matrix(original.joint_states.values, original.transmission_error.values[:, 0],
                          a_js, a_te)
    repl = _signal_matrix(new.joint_states.values, new.transmission_error.values[:, 0],
                          b_js, b_te)
    result.identical = all(np.array_equal(x, y) for x, y in zip(orig, repl))

    # Sensitivity of the original to each physical event moved by ±J_k ticks.
    base = replay_in_process(original)
    base_cols = _signal_matrix(base.joint_states, base.transmission_error, a_js, a_te)
    bound = [np.zeros(()) for _ in base_cols]
    for (index, _), budget in zip(events, budgets):
        worst = [0.0] * len(base_cols)
        for steps in (-budget, budget):
            if original.events[index][1].step + steps < original.parameters.start_step:
                continue
            moved = replay_in_process(shift_event(original, index, steps))
            cols = _signal_matrix(moved.joint_states, moved.transmission_error, a_js, a_te)
            worst = [max(w, float(np.max(np.abs(c - b), initial=0.0)))
                     for w, c, b in zip(worst, cols, base_cols)]
        bound = [b + w for b, w in zip(bound, worst)]

    names = signal_names(original)
    times_js = original.joint_states.steps[a_js] * original.dt
    times_te = original.transmission_error.steps[a_te] * original.dt
    for c, ((name, unit), x, y, b) in enumerate(zip(names, orig, repl, bound)):
        if len(x) == 0:
            continue
        floor = max(FLOOR_REL * float(np.max(np.abs(x))), FLOOR_ABS[unit])
        times = times_te if c == 9 else times_js
        result.signals.append(signal_error(name, unit, np.abs(y - x), times,
                                           SAFETY * float(b) + floor))
    return result


def format_comparison(c: Comparison) -> str:
    """What ``replay_run --compare`` prints."""
    lines = ['free-running replay vs original (events land where the wall clock put them, so '
             'the runs are judged by a tolerance, not compared for identity): event timing (integration steps; one publish tick = '
             f'{c.ticks} steps)']
    for t in c.timings:
        lines.append(f'  {t.what:<32} recorded step {t.original_step:>9}  replayed '
                     + ('never' if t.new_step is None else
                        f'{t.new_step:>9}  delay {t.delay:+d}'))
    lines.append(f'  largest timing difference: {c.jitter_ticks:g} publish ticks')
    lines.append(f'trajectory difference at {c.samples} common samples ({c.excluded} within '
                 'the timing budget of an event left out); tolerance = '
                 f'{SAFETY:g} × Σ over events of the deviation when that event alone moves by '
                 '± its delay (whole ticks, at least one)')
    lines.append(f'  {"signal":<26}{"unit":<7}{"max diff":>12}{"RMS diff":>12}'
                 f'{"at t [s]":>11}{"tolerance":>12}  verdict')
    for s in c.signals:
        lines.append(f'  {s.name:<26}{s.unit:<7}{s.max_error:>12.3e}{s.rms_error:>12.3e}'
                     f'{s.at_time:>11.4f}{s.tolerance:>12.3e}  {"ok" if s.ok else "FAIL"}')
    if c.identical:
        lines.append('  the replay reproduces the original bit for bit')
    lines.append('  RESULT: ' + ('PASS' if c.ok else 'FAIL'))
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

    @property
    def ok(self) -> bool:
        return (self.missing is None and self.first_difference is None
                and all(t.delay == 0 for t in self.timings))


def exact_comparison(original: RecordedRun, new: RecordedRun) -> ExactComparison:
    """Every physical event at its recorded step, and every output sample of
    ``original`` equal bit for bit in ``new`` (which may run on past its end). Raises
    :class:`NothingToCompare` when no sample is compared."""
    timings = match_events(original, new)
    names = [name for name, _ in signal_names(original)]
    columns = [(original.joint_states, new.joint_states, names[:9]),
               (original.transmission_error, new.transmission_error, names[9:])]
    first: Difference | None = None
    missing = None
    samples = 0
    for a, b, signal in columns:
        n = len(a)
        if len(b) < n:
            missing = (f'the replay has {len(b)} samples of {signal[0]}, the original {n}')
            n = len(b)
        samples += n
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
    if not samples:
        raise NothingToCompare(f'{new.path} holds none of the {len(original.joint_states)} '
                               f'output samples of {original.path}: there is nothing to '
                               'compare')
    return ExactComparison(timings, samples, first, missing)


def format_exact(c: ExactComparison) -> str:
    """What ``replay_run --compare`` prints for a lockstep replay."""
    late = [t for t in c.timings if t.delay != 0]
    lines = ['replay vs original (lockstep: every event must take effect at its recorded '
             'step and every output must be identical)',
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
    lines.append('  RESULT: ' + ('IDENTICAL: the replay reproduces the original bit for bit'
                                 if c.ok else 'DIFFERENT'))
    return '\n'.join(lines)


__all__ = ['SAFETY', 'NothingToCompare', 'EventTiming', 'Comparison', 'match_events', 'shift_event',
           'compare_runs', 'format_comparison', 'Difference', 'ExactComparison',
           'exact_comparison', 'format_exact']
