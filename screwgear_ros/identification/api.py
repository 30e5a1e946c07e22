"""``identify``: fit the table model's parameters to recordings (output error).

Every evaluation re-simulates the recorded commands through the node's own session
(:mod:`~screwgear_ros.identification.adapter`) and compares the simulated measured angles (and
speeds) with the recorded ones (:mod:`~screwgear_ros.identification.problem`);
``scipy.optimize.least_squares`` minimizes the difference within bounds
(:mod:`~screwgear_ros.identification.fit`), and the Jacobian at the optimum gives intervals,
correlations and the parameters the data cannot determine
(:mod:`~screwgear_ros.identification.stats`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .adapter import CommandRefused, Diverged, base_values, mesh_hz, simulate, tick_period
from .checks import (
    check_joints,
    check_options,
    check_paths,
    check_recordings,
    probe_bounds,
    report_stem,
    written_paths,
)
from .errors import FitFailed, IdentifyError, RecordingError, TooShortError
from .fit import FitOutcome, first_stage, minimize
from .known import fixed
from .output import rehearse, write_fitted
from .parameters import fit_parameters, starts, values_of
from .problem import DIVERGED, Comparison, Problem, compare
from .recording import MESH_PARAMETERS, check_rate, read_recording
from .report import write_report
from .resid import Analysis, analyse, drifting, half_widths, judged
from .samples import NODE_JOINTS, Recording
from .startvalues import data_starts, moved
from .stats import Estimate, Statistics, disagreements, start_disagreements, statistics
from .workers import Evaluator

#: Samples (per compared joint, over all fit recordings) needed per fitted parameter.
SAMPLES_PER_PARAMETER = 250


@dataclass
class IdentifyResult:
    """What a fit found: the fitted values with intervals (:attr:`estimates`), the
    correlation matrix, the measured-against-simulated comparisons, the files written,
    and what it cost.

    Examples
    --------
    >>> from screwgear_ros import IdentifyResult
    >>> sorted(f for f in IdentifyResult.__dataclass_fields__)[:3]
    ['analysis', 'comparisons', 'cost']
    """

    values: dict[str, float]
    statistics: Statistics
    comparisons: list[Comparison]
    finished: bool
    cost: float
    simulations: int
    seconds: float
    sim_seconds: float
    message: str = ''
    output: Path | None = None
    report: Path | None = None
    figure: Path | None = None
    start_costs: list[float] = field(default_factory=list)
    start_values: list[dict[str, float]] = field(default_factory=list)
    stopped: str = ''
    analysis: Analysis | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def estimates(self) -> tuple[Estimate, ...]:
        return self.statistics.estimates

    @property
    def correlation(self) -> np.ndarray:
        return self.statistics.correlation

    @property
    def undetermined(self) -> list[str]:
        """Names of the parameters the recordings cannot determine."""
        return [e.name for e in self.statistics.undetermined]

    def fit_percent(self, role: str = 'fit', which: str = 'after') -> np.ndarray:
        """The fit % (100·(1 − NRMSE)) of each recording and joint.

        Parameters
        ----------
        role : str
            ``'fit'`` (the recordings fitted to) or ``'validate'``.
        which : str
            ``'before'`` (the base file's values) or ``'after'`` (the fitted ones).

        Returns
        -------
        ndarray
            (recordings, joints) fit %.
        """
        return np.array([c.fit(which) for c in self.comparisons if c.role == role])


def _read(bags: Sequence[str | os.PathLike[str]], joints: Mapping[str, str] | None,
          input_delay: float, period: float, clock: str,
          namespace: str | None) -> tuple[Recording, ...]:
    recordings = tuple(read_recording(b, joints, input_delay, clock, period, namespace)
                       for b in bags)
    return recordings


def _reversals(base: Mapping[str, Any], recordings: Sequence[Recording]) -> list[int]:
    """The reversals the node applies in each recording at the base values (a recorded
    command the node refuses there is refused now; base values at which the model
    diverges are a large residual to fit from)."""
    counts: list[int] = []
    for recording in recordings:
        try:
            simulate(base, recording, reversals=counts)
        except CommandRefused as exc:
            raise RecordingError(str(exc)) from None
        except Diverged:
            pass
    return counts


def _diverged_everywhere(problem: Problem, values: Mapping[str, Any], simulations: int) -> str:
    """Why the model cannot run at ``values``, for a fit that found no point it runs at."""
    for recording in problem.recordings:
        try:
            simulate(values, recording, problem.speeds)
        except Diverged as exc:
            where = f'in {recording.path}, {exc}'
            break
    else:
        where = 'no finite residual'
    fitted = ', '.join(f'{p.name} = {values[p.name]:.6g}' for p in problem.fitted)
    return (f'the model diverged at every point the fit tried ({simulations} simulations): '
            f'at the best of them ({fitted}), {where}; narrow --bounds to values where the '
            'model runs, or start from a base file it runs with')


def identify(bags: Sequence[str | os.PathLike[str]], params: str | os.PathLike[str],
             fit: Sequence[str], *, bounds: Mapping[str, tuple[float, float]] | None = None,
             validate: Sequence[str | os.PathLike[str]] = (), output: str | os.PathLike[str]
             | None = None, report: str | os.PathLike[str] | None = None,
             workers: int = 1, scheduler: str | None = None,
             joints: Mapping[str, str] | None = None, input_delay: float = 0.0,
             clock: str = 'stamp', settle: float = 0.0,
             fix: Mapping[str, float] | None = None, speeds: bool = False,
             starts_count: int = 3, seed: int = 0, max_evaluations: int = 40,
             progress: bool = False, namespace: str | None = None) -> IdentifyResult:
    """Fit the parameters ``fit`` of the base file ``params`` to the recordings ``bags``.

    Parameters
    ----------
    bags : sequence of path
        Recordings to fit (rosbag2, MCAP or sqlite3): joint_states and the commands.
    params : path
        The base parameter file (table_sim's ``--params-file`` format).
    fit : sequence of str
        Names of the real-valued, writable parameters to fit.
    bounds : mapping, optional
        name → (low, high), within the declared range (default: base/10 … base·10).
    validate : sequence of path
        Recordings compared before and after, not fitted.
    output : path, optional
        FITTED.yaml to write (the base file with the fitted values).
    report : path, optional
        Stem of the report (``.md`` and ``.png``); default: beside ``output``.
    workers : int
        Processes simulating the Jacobian's trial points (1: this process).
    scheduler : str, optional
        A Dask scheduler address to simulate them on instead.
    joints : mapping, optional
        Node joint name → the bags' name (written to ``output`` as ``joint_names``).
    input_delay : float
        Ticks of the model (a fraction too) by which the drive applies a command after
        its log time.
    clock : str
        ``'stamp'``: a sample is compared at its header stamp (default); ``'log'``: at
        its log time.
    settle : float
        Seconds at each recording's start left out of the comparison, for the model's
        state to settle (a recording that does not start at rest).
    fix : mapping, optional
        name → value: parameters held at these values instead of the base file's.
    speeds : bool
        Compare the speeds too.
    starts_count, seed : int
        Starting points (the base values, then seeded draws), reproducibly.
    max_evaluations : int
        Residual evaluations per starting point.
    progress : bool
        Show a progress bar (tqdm) with the cost and iteration.
    namespace : str, optional
        The table's namespace in bags that hold several tables' topics.

    Returns
    -------
    IdentifyResult
        ``finished`` False when Ctrl-C stopped the fit (the best point so far, written);
        ``stopped`` says what was written when Ctrl-C came while writing.

    Raises
    ------
    IdentifyError
        Bad input (:mod:`~screwgear_ros.identification.errors`), before any fit starts,
        or a model that diverged at every point tried.

    Examples
    --------
    >>> import screwgear_ros
    >>> result = screwgear_ros.identify(['run_bag'], 'config/realistic.yaml',
    ...                                 ['inertia_table'], output='fitted.yaml')  # doctest: +SKIP
    >>> result.values['inertia_table']  # doctest: +SKIP
    46.1
    """
    began = time.perf_counter()
    workers, starts_count, seed, max_evaluations, input_delay, settle = check_options(
        workers, scheduler, starts_count, seed, max_evaluations, input_delay, settle)
    if isinstance(fit, str) or isinstance(bags, str | os.PathLike):
        raise IdentifyError('bags and fit are sequences (a list of paths, a list of names)')
    check_paths(bags, validate, params, written_paths(output, report))
    check_joints(joints)
    base = fixed(base_values(params), fix or {}, fit)
    fitted = fit_parameters(list(fit), base, bounds)
    trials = probe_bounds(base, fitted)
    settings = {'joint_names': [dict(joints or {}).get(j, j) for j in NODE_JOINTS]} \
        if joints else {}
    if output is not None:
        rehearse(params, output, trials, settings)
    period = tick_period(base)
    recordings = _read(bags, joints, input_delay, period, clock, namespace)
    checks = _read(validate, joints, input_delay, period, clock, namespace)
    check_recordings((*recordings, *checks), input_delay, period, speeds)
    aliased = check_rate(recordings, fit, mesh_hz(base)) if any(
        name in MESH_PARAMETERS for name in fit) else []
    problem = Problem(base, fitted, recordings, speeds, settle)
    needed = SAMPLES_PER_PARAMETER * len(fitted)
    have = sum(int(np.sum(problem.compared(r))) for r in recordings)
    if have < needed:
        raise TooShortError(f'{have} samples (after losses and --settle) are too short to fit '
                            f'{len(fitted)} parameter(s): at least {needed} samples '
                            f'({needed * period:.3g} s at {1 / period:g} Hz) are needed')
    reversals = _reversals(base, recordings)
    _reversals(base, checks)
    weights = problem.weights
    with contextlib.ExitStack() as stack:
        try:
            evaluator = stack.enter_context(Evaluator(problem, weights, workers, scheduler))
        except (OSError, TimeoutError, ValueError) as exc:
            raise IdentifyError(f'--scheduler {scheduler}: cannot connect: {exc}') from None
        found = data_starts(fitted, recordings)
        outcome = minimize(evaluator, fitted,
                           moved(fitted, starts(fitted, starts_count, seed), found),
                           max_evaluations, progress, first_stage(fitted, list(found)))
        describe = evaluator.describe()
        simulations, sim_seconds = evaluator.simulations, evaluator.sim_seconds
    if np.all(outcome.residual == DIVERGED):
        raise FitFailed(_diverged_everywhere(problem, problem.values(outcome.x), simulations))
    stats = assessed(problem, outcome, sum(reversals))
    values = values_of(fitted, outcome.x)
    after = {**base, **values}
    comparisons = compare(problem, recordings, base, after, 'fit') + \
        compare(problem, checks, base, after, 'validate')
    analysis = analyse(comparisons, dict(base), problem.settle,
                       drifting(fitted, outcome.jacobian, outcome.residual,
                                half_widths(fitted, stats.estimates)))
    stats = judged(stats, analysis)
    notes = [f'{r.path}: {line}' for r in (*recordings, *checks) for line in r.timing]
    notes += aliased
    notes += [f'{name}: started from {value:.6g}, {why}' for name, (value, why) in found.items()]
    notes += [f'{name}: held at {value:.6g} (--fix)' for name, value in (fix or {}).items()]
    if problem.settle:
        notes.append(f'the first {problem.settle:g} s of each recording settle the state '
                     '(left out of the comparison); the simulation starts at rest there')
    else:
        notes.append('each simulation starts at rest (the preload equilibrium) at its '
                     'recording\'s first sample or command')
    result = IdentifyResult(values, stats, comparisons, outcome.finished, outcome.cost,
                            simulations, 0.0, sim_seconds, outcome.message,
                            start_costs=outcome.start_costs,
                            start_values=[values_of(fitted, x) for x in outcome.start_points],
                            analysis=analysis, notes=notes)
    written: list[Path] = []
    try:
        if output is not None:
            header = [(f'Fitted by identify to {", ".join(str(b) for b in bags)}: '
                      f'{", ".join(values)}.')]
            if not outcome.finished:
                header.insert(0, 'UNFINISHED: the fit was interrupted; these are the best '
                              'values found so far.')
            result.output = write_fitted(params, output, stats.estimates, header, settings)
            written.append(result.output)
        stem = report_stem(output, report)
        result.seconds = time.perf_counter() - began
        if stem is not None:
            result.report, result.figure = write_report(
                stem, stats, comparisons, finished=outcome.finished,
                fitted_path=str(output), simulations=simulations, seconds=result.seconds,
                sim_seconds=sim_seconds, workers=describe, speeds=speeds,
                starts=list(zip(result.start_values, outcome.start_costs, strict=True)),
                sections=[*analysis.lines(), '## Recordings and starting points', '',
                          *(f'- {note}' for note in notes), ''])
    except KeyboardInterrupt:
        # each file is written whole or not at all: say which are there
        done = ', '.join(str(p) for p in written)
        result.stopped = 'interrupted (SIGINT) while writing: ' + (
            f'{done} written complete' if written else 'no file written')
    return result


def assessed(problem: Problem, outcome: FitOutcome, reversals: int) -> Statistics:
    """The statistics of a fit's outcome, with the recordings' and the starts'
    disagreements."""
    rho = problem.lag_correlation(outcome.residual)
    stats = statistics(problem.fitted, outcome.x, outcome.residual, outcome.jacobian, rho,
                       reversals)
    warnings: list[str] = []
    if outcome.jacobian is not None:
        sizes = [r.samples * len(problem.columns) for r in problem.recordings]
        warnings += disagreements(problem.fitted, outcome.x, outcome.residual,
                                  outcome.jacobian, sizes,
                                  [r.path for r in problem.recordings], len(problem.columns))
    warnings += start_disagreements(problem.fitted, stats.estimates, outcome.start_points,
                                    outcome.start_costs)
    return dataclasses.replace(stats, warnings=tuple(warnings))


__all__ = ['SAMPLES_PER_PARAMETER', 'IdentifyResult', 'assessed', 'identify']
