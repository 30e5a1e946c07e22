"""The verdict on a recorded run: what is compared, against what, and the report.

Every signal's error against the reference (:mod:`.reference`) is weighed against its
tolerance (:mod:`.tolerance`); the recorded active_path, header stamps and measured
joint_states are checked as well, and :func:`check_run` gathers it all in a
:class:`CheckReport` that :func:`format_report` prints.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from ...bag.errors import BagError, InvalidBag
from ...bag.reader import RecordedRun
from ...numerics import dop853
from ...numerics.reference import RTOL
from ...physics.drive import active_path
from ...physics.sensors import SensorChain
from ...sim.events import ParameterChange, Reset
from ...sim.plant import DriveInput
from ...sim.session import ROW, AdvanceMode, Session
from ..replay_in_process import ReplayedOutputs, replay_in_process
from .forked import Forked
from .reference import mesh_of, reference_outputs, signal_names
from .tolerance import (
    FLOOR_ABS,
    FLOOR_REL,
    REFERENCE_REFINE,
    SAFETY,
    SAFETY_FIXED_STEP,
    TABLE_ENCODER_BITS,
    TABLE_ENCODER_COUNT,
    SignalError,
    fine_replay,
    signal_error,
)


@dataclass
class CheckReport:
    """Everything check_run prints."""

    path: str
    dt: float
    duration: float                  # simulated time covered, s
    events: int
    resets: int
    signals: list[SignalError] = field(default_factory=list)
    safety: float = SAFETY           # tolerance = safety × Richardson estimate
    replay_identical: bool = False   # in-process RK4 replay equals the recording bit for bit
    replay_max_diff: float = 0.0
    truncated: str | None = None
    summary: str | None = None       # what is wrong with the bag's summary section
    stamp_mismatches: list[tuple[int, int]] = field(default_factory=list)  # (log time, stamp)
    samples: int = 0                 # values compared, over every signal
    path_changes: int = 0            # active_path messages expected (with the start's)
    path_mismatch: str | None = None  # how the recorded active_path differs, if it does
    #: joint_states measured by non-ideal sensors: the samples checked against the sensor
    #: model of the exact state (0: the sensors are ideal and joint_states is exact)
    sensor_samples: int = 0
    sensor_mismatch: str | None = None   # where the measured joint_states first differ
    #: how the steps were found in a bag whose log times are arrival times (None: its
    #: log times are the simulation's)
    timing: str | None = None
    parameters_from: str = "the bag's run_parameters"   # where the model comes from

    @property
    def ok(self) -> bool:
        """Every signal within tolerance and every recorded output what the recorded
        inputs make: the in-process replay gives the recording's bits (the node's own
        tick), whatever the reference's tolerance would allow."""
        return (self.samples > 0 and all(s.ok for s in self.signals)
                and not self.stamp_mismatches and self.path_mismatch is None
                and self.sensor_mismatch is None and self.replay_identical)

    @property
    def table_angle(self) -> SignalError | None:
        """The table position's error (the second joint of :func:`signal_names`)."""
        return self.signals[1] if len(self.signals) > 1 else None

    @property
    def undecided(self) -> list[SignalError]:
        """The signals the reference cannot judge, if nothing else fails: then no verdict."""
        if (any(not s.ok and not s.undecided for s in self.signals) or self.stamp_mismatches
                or self.path_mismatch is not None or self.sensor_mismatch is not None
                or not self.replay_identical):
            return []
        return [s for s in self.signals if s.undecided]




class NothingToCompare(BagError):
    """A comparison with no sample to compare: never a PASS. A :class:`BagError`, so
    every tool that reports an unusable bag reports it (exit 2 with this reason)."""


#: The signals of mesh_state, in its columns' order (δ, δ̇ and F of meshes 1 and 3).
MESH_SIGNALS = [('mesh_state δ1', 'm'), ('mesh_state δ3', 'm'), ('mesh_state dδ1/dt', 'm/s'),
                ('mesh_state dδ3/dt', 'm/s'), ('mesh_state F1', 'N'), ('mesh_state F3', 'N')]


def require_samples(run: RecordedRun) -> None:
    """Raise :class:`NothingToCompare` unless ``run`` has every output table_sim records
    (joint_states, transmission_error, mesh_state after the start of the run, and the
    active_path of the start): a check that compared fewer would judge nothing."""
    start = run.parameters.start_step
    missing = [name for name, signal in (('joint_states', run.true_joint_states),
                                         ('transmission_error', run.transmission_error),
                                         ('mesh_state', run.mesh_state))
               if not np.any(signal.steps > start)]
    if not len(run.active_path):
        missing.append('active_path')
    if missing:
        why = f' (the readable part ends there: {run.truncated})' if run.truncated else ''
        raise NothingToCompare(
            f'{run.path} holds no {", ".join(missing)} sample after the start of the run '
            f'(step {start}), so there is nothing to compare{why}; table_sim records '
            'joint_states, transmission_error and mesh_state every tick and active_path '
            'at the start and at every change')
    if run.measured is None and not all(
            s.sensors.ideal for s in [run.parameters.settings] + [
                e.settings for _, e in run.events if isinstance(e, ParameterChange)]):
        raise InvalidBag(f'{run.path}: its joint sensors are not ideal '
                       '(run_parameters), but it holds no true_joint_states: the exact state '
                       'was not recorded, so the physics cannot be judged')
    if not np.array_equal(run.mesh_state.steps, run.true_joint_states.steps[:len(run.mesh_state)]):
        raise InvalidBag(f'{run.path}: mesh_state and joint_states samples are not '
                       'published at the same steps')
    _require_measured_aligned(run)


def _require_measured_aligned(run: RecordedRun) -> None:
    """Raise :class:`InvalidBag` when the measured joint_states are not one per
    true_joint_states at its step (a message missing, duplicated, or moved to another
    topic): the node publishes both every tick, so that is a damaged bag, not physics."""
    measured = run.measured
    if measured is None:
        return
    topic = run.names.get('joint_states', 'joint_states')
    exact = run.true_joint_states
    n = min(len(exact), len(measured))
    if len(exact) != len(measured) and not run.truncated:
        raise InvalidBag(f'{run.path}: {topic} has {len(measured)} samples, '
                         f'true_joint_states {len(exact)}: the node publishes both every '
                         'tick, so a message is missing, extra or on another topic')
    off = np.flatnonzero(exact.steps[:n] != measured.steps[:n])
    if len(off):
        i = int(off[0])
        raise InvalidBag(f'{run.path}: {topic} sample {i} is at step {measured.steps[i]}, '
                         f'true_joint_states at step {exact.steps[i]}: the node publishes '
                         'both at every tick\'s step')


def path_changes(run: RecordedRun, replayed: ReplayedOutputs) -> list[tuple[int, int]]:
    """(step, path) of the start and of every change of the active path, as the
    in-process replay applied the recorded events (the node publishes active_path then)."""
    path = active_path(run.parameters.params.mode, DriveInput().direction)
    changes = [(run.parameters.start_step, path)]
    for tick in replayed.ticks:
        if tick.outputs.active_path != changes[-1][1]:
            changes.append((tick.start, tick.outputs.active_path))
    return changes


#: Ticks an active_path change may be recorded after its step in a bag with arrival times.
ARRIVAL_LAG = 2


def _path_mismatch(run: RecordedRun, replayed: ReplayedOutputs) -> str | None:
    """What differs between the recorded active_path and the replay's, or None."""
    end = run.end_step      # a change at or after the last output is not checked (cut bag)
    expected = [c for c in path_changes(run, replayed) if c[0] < end]
    recorded = [(int(s), int(v)) for s, v in zip(run.active_path.steps.tolist(),
                                                 run.active_path.values[:, 0].tolist(), strict=False)
                if s < end]
    if recorded == expected:
        return None
    # Arrival times (bag/retime.py): a recorder may take a latched active_path after the
    # next tick's outputs, so a change may be placed up to ARRIVAL_LAG ticks late.
    lag = ARRIVAL_LAG * run.parameters.settings.steps_per_publish if run.timing else 0
    for k, (a, b) in enumerate(zip(recorded, expected, strict=False)):
        if a[1] != b[1] or not b[0] <= a[0] <= b[0] + lag:
            return (f'change {k + 1}: recorded path {a[1]} at t = {a[0] * run.dt:.6f} s, '
                    f'the replay gives path {b[1]} at t = {b[0] * run.dt:.6f} s')
    if len(recorded) == len(expected):
        return None
    return (f'{len(recorded)} recorded changes (with the start), the replay gives '
            f'{len(expected)}')


def sensor_rows(run: RecordedRun) -> np.ndarray:
    """What the run's sensors measure of its exact joint states: joint_states rows (n, 9),
    sample by sample through :class:`~screwgear_ros.physics.sensors.SensorChain`, restarted by
    each recorded reset and reconfigured by each recorded parameter change at the sample
    of the tick that applied it (the first sample recorded after it), as the node's
    session does."""
    exact = run.true_joint_states
    chain = SensorChain(run.parameters.settings.sensors, run.dt)
    events = [(order, e) for order, e in run.events if isinstance(e, (Reset, ParameterChange))]
    takes = np.searchsorted(exact.order, [order for order, _ in events], side='right').tolist()
    rows = exact.values.copy()
    k = 0
    for i, (step, values) in enumerate(zip(exact.steps.tolist(), exact.values.tolist(), strict=False)):
        while k < len(events) and takes[k] <= i:
            event = events[k][1]
            if isinstance(event, Reset):
                chain.restart()
            else:
                chain.configure(event.settings.sensors)
            k += 1
        position, velocity = chain.measure_values(step, values[0:3], values[3:6])
        rows[i, 0:6] = (*position, *velocity)
    return rows


def sensor_mismatch(run: RecordedRun) -> tuple[int, str | None]:
    """(samples compared, where the recorded joint_states first differ from
    :func:`sensor_rows` bit for bit, or None); (0, None) for a bag whose joint_states
    are the exact state. :class:`InvalidBag` when they are not one per true_joint_states
    sample (:func:`require_samples` refuses such a bag first)."""
    measured = run.measured
    if measured is None:
        return 0, None
    topic = run.names.get('joint_states', 'joint_states')
    exact = run.true_joint_states
    n = min(len(exact), len(measured))
    _require_measured_aligned(run)
    steps = exact.steps[:n]
    expected = sensor_rows(run)[:n]
    differs = np.flatnonzero(np.any(expected.view(np.int64)
                                    != measured.values[:n].view(np.int64), axis=1))
    if not len(differs):
        return n, None
    i = int(differs[0])
    c = int(np.flatnonzero(expected[i].view(np.int64) != measured.values[i].view(np.int64))[0])
    name, unit = signal_names(run)[c]
    return n, (f'{topic} differs from what the recorded sensor model measures of '
               f'true_joint_states from tick {i} on (step {int(steps[i])}, '
               f't = {steps[i] * run.dt:.6f} s): {name} recorded '
               f'{float(measured.values[i, c])!r} {unit}, the model gives '
               f'{float(expected[i, c])!r} ({len(differs)} of {n} samples differ)')


def _loose_reference(run: RecordedRun, rk4: ReplayedOutputs,
                     progress: Callable[[float], None] | None,
                     forked: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference at rtol RTOL (the looser one), telling ``progress`` only where it
    runs in this process."""
    return reference_outputs(run, rk4, None if forked else progress, RTOL)


def _load_kernels(run: RecordedRun) -> None:
    """Load the check's kernels (RK4's ticks, the observation, DOP853) in this process
    before it forks, so that the children inherit them instead of each loading its own:
    one tick of a session of the run's start, and :func:`dop853.warm`. Only a head start:
    whatever fails here is left to the check itself to meet and report."""
    start = run.parameters
    try:
        Session(start.params, start.settings, np.asarray(start.initial_state),
                start.start_step).advance(1, mode=AdvanceMode.ROWS, rows=np.empty((1, ROW)))
        dop853.warm()
    except Exception:  # noqa: BLE001, S110 - the check raises it, at its place in the order
        pass


def check_run(run: RecordedRun, progress: Callable[[float], None] | None = None,
              parallel: bool = True) -> CheckReport:
    """Compare a recorded run with the reference solution; see the module docstring.
    ``parallel``: the replay at dt/2 and the reference at the looser tolerance run in
    forked processes meanwhile (same result). Raises :class:`NothingToCompare` for a
    run without outputs to compare."""
    require_samples(run)
    half = None if progress is None else (lambda seconds: progress(seconds / 2))
    if parallel:
        _load_kernels(run)
    fine = Forked(partial(fine_replay, run), parallel, 'check_run RK4 dt/2')
    loose: Forked[tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None
    try:
        rk4 = replay_in_process(run, 1)
        loose = Forked(partial(_loose_reference, run, rk4, half), parallel,
                       f'check_run reference rtol {RTOL:g}')
        try:
            ref_js, ref_te, ref_mesh = reference_outputs(
                run, rk4, progress if loose.forked else half, RTOL / REFERENCE_REFINE)
            mesh_rk4 = mesh_of(run, rk4, rk4.joint_states)
        except Exception:
            loose.result()      # solved first one after the other: its failure is the one told
            raise
        looser = loose.result()
        fine_js, fine_te = fine.result()
    finally:
        fine.close()
        if loose is not None:
            loose.close()
    recorded = run.true_joint_states.values
    times_js = run.true_joint_states.steps * run.dt
    times_te = run.transmission_error.steps * run.dt
    report = CheckReport(
        str(run.path), run.dt,
        (run.end_step - run.parameters.start_step) * run.dt,
        len(run.events), sum(isinstance(e, Reset) for _, e in run.events),
        safety=SAFETY if run.parameters.settings.contact_location else SAFETY_FIXED_STEP,
        truncated=run.truncated, summary=run.summary,
        stamp_mismatches=list(run.stamp_mismatches), timing=run.timing,
        parameters_from=run.parameters_from)
    rec_te = run.transmission_error.values[:, 0]
    diff_js = np.abs(rk4.joint_states - recorded)
    diff_te = np.abs(rk4.transmission_error - rec_te)
    report.replay_max_diff = float(max(np.max(diff_js, initial=0.0), np.max(diff_te, initial=0.0)))
    report.replay_identical = bool(np.array_equal(rk4.joint_states, recorded)
                                   and np.array_equal(rk4.transmission_error, rec_te))
    columns = [(recorded[:, c], ref_js[:, c], looser[0][:, c],
                rk4.joint_states[:, c] - fine_js[:, c], times_js) for c in range(9)]
    columns.append((rec_te, ref_te, looser[1], rk4.transmission_error - fine_te, times_te))
    m = len(run.mesh_state)
    richardson_mesh = mesh_rk4 - mesh_of(run, rk4, fine_js)
    columns += [(run.mesh_state.values[:, c], ref_mesh[:m, c], looser[2][:m, c],
                 richardson_mesh[:m, c], times_js[:m]) for c in range(6)]
    for (name, unit), (rec, ref, ref_loose, richardson, times) in zip(
            signal_names(run) + MESH_SIGNALS, columns, strict=False):
        estimate = float(np.max(np.abs(richardson)))
        scale = float(np.max(np.abs(ref)))
        tolerance = max(report.safety * estimate, FLOOR_REL * scale, FLOOR_ABS[unit])
        report.signals.append(signal_error(name, unit, np.abs(rec - ref), times, tolerance,
                                           estimate, float(np.max(np.abs(ref - ref_loose)))
                                           / (REFERENCE_REFINE - 1.0)))
        report.samples += len(rec)
    report.path_changes = len(path_changes(run, rk4))
    report.path_mismatch = _path_mismatch(run, rk4)
    report.sensor_samples, report.sensor_mismatch = sensor_mismatch(run)
    return report


def format_report(report: CheckReport) -> str:
    """The human-readable report check_run prints."""
    lines = [
        f'check_run {report.path}',
        (f'  {report.duration:.3f} s simulated at dt = {report.dt * 1e6:g} µs, '
        f'{report.events} recorded events ({report.resets} resets)'),
        f'  parameters: {report.parameters_from}',
    ]
    if report.truncated:
        lines.append(f'  WARNING: {report.truncated}; checked what is readable')
    if report.summary:
        lines.append(f'  NOTE: {report.summary}; it is not used: the channels and messages '
                     'are read from the data section (the index rebuilt from the data)')
    lines += [
        (f'  reference: DOP853 (compiled, adaptive), rtol {RTOL / REFERENCE_REFINE:g}, '
        'restarted at every input/parameter change and reset; its own error ("ref. err") is '
        f'taken as its difference from the solution at rtol {RTOL:g} ÷ '
        f'{REFERENCE_REFINE - 1:g}: a signal within that of its tolerance is undecided'),
        (f'  tolerance = max({report.safety:g} × |RK4(dt) − RK4(dt/2)|, {FLOOR_REL:g} × '
        'max|signal|): Richardson\'s estimate of RK4\'s global error'),
        ('  (15/16 of it for a 4th-order method, kept through backlash impacts by locating '
         'contact changes),' if report.safety == SAFETY else
         '  (15/16 of it for a 4th-order method; recorded with the fixed step, whose order '
         'impacts lower),') + f' with a safety factor {report.safety:g}',
        (f'  {"signal":<26}{"unit":<7}{"max error":>12}{"RMS error":>12}{"at t [s]":>11}'
        f'{"RK4 est.":>12}{"ref. err":>12}{"tolerance":>12}  verdict'),
    ]
    for s in report.signals:
        lines.append(f'  {s.name:<26}{s.unit:<7}{s.max_error:>12.3e}{s.rms_error:>12.3e}'
                     f'{s.at_time:>11.4f}{s.estimate:>12.3e}{s.reference_error:>12.3e}'
                     f'{s.tolerance:>12.3e}  '
                     + ('ok' if s.ok else 'undecided' if s.undecided else 'FAIL'))
    table = report.table_angle
    if table is not None:
        lines.append(f'  table angle error {table.max_error:.2e} rad = '
                     f'{table.max_error / TABLE_ENCODER_COUNT:.3g} counts of a '
                     f'{TABLE_ENCODER_BITS}-bit table encoder ({TABLE_ENCODER_COUNT:.2e} rad '
                     'a count)')
    lines.append('  in-process RK4 replay of the recorded inputs: '
                 + ('identical to the recording, bit for bit' if report.replay_identical
                    else f'differs from the recording by up to {report.replay_max_diff:.3e}'))
    lines.append(f'  active_path: {report.path_changes} messages expected (the start and '
                 'every change, as the replay applied the recorded events): '
                 + (f'FAIL: {report.path_mismatch}' if report.path_mismatch is not None
                    else 'every one recorded at its step' if report.timing is None
                    else f'every one recorded at its step or at most {ARRIVAL_LAG} ticks '
                    'after it (arrival times)'))
    if report.sensor_mismatch is not None:
        lines.append(f'  measured joint_states: FAIL: {report.sensor_mismatch}')
    elif report.sensor_samples:
        lines.append(f'  measured joint_states: {report.sensor_samples} samples follow from '
                     'true_joint_states by the recorded sensor model, bit for bit (the '
                     'signals above are the exact state)')
    else:
        lines.append('  joint_states: the sensors are ideal, so they are the exact state')
    lines.append(f'  {report.samples} recorded values compared')
    if report.stamp_mismatches:
        log_time, stamp = report.stamp_mismatches[0]
        lines.append(f'  joint_states header stamps: {len(report.stamp_mismatches)} differ from '
                     f'their log time (first: log time {log_time} ns, stamp {stamp} ns)')
    else:
        lines.append('  joint_states header stamps: every one equals its log time'
                     if report.timing is None else f'  NOTE: {report.timing}')
    undecided = report.undecided
    if undecided:
        worst = max(undecided, key=lambda s: s.reference_error / s.tolerance)
        lines.append(f'  RESULT: UNDECIDED: {", ".join(s.name for s in undecided)} within the '
                     f'reference\'s own error of the tolerance (e.g. {worst.name}: error '
                     f'{worst.max_error:.3e}, reference error {worst.reference_error:.3e}, '
                     f'tolerance {worst.tolerance:.3e}): the reference cannot judge this run')
        return '\n'.join(lines)
    failed = [s.name for s in report.signals if not s.ok]
    problems = [f'{", ".join(failed)} outside tolerance'] if failed else []
    if report.stamp_mismatches:
        problems.append('joint_states header stamps differ from their log times')
    if report.path_mismatch is not None:
        problems.append('active_path differs from the replay')
    if report.sensor_mismatch is not None:
        problems.append('joint_states do not follow from true_joint_states by the sensor '
                        'model')
    if not report.replay_identical:
        problems.append('the recording is not what its recorded inputs make (the in-process '
                        f'replay differs by up to {report.replay_max_diff:.3e})')
    if not report.samples:
        problems.append('nothing compared')
    lines.append('  RESULT: ' + ('PASS: every signal within its tolerance' if not problems
                                 else f'FAIL: {"; ".join(problems)}'))
    return '\n'.join(lines)

