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
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .adapter import Diverged, base_values, mesh_hz, simulate, tick_period
from .errors import TooShortError
from .fit import first_stage, minimize
from .known import fixed
from .output import write_fitted
from .parameters import fit_parameters, starts, values_of
from .problem import Comparison, Problem, compare
from .recording import MESH_PARAMETERS, check_rate, read_recording
from .report import write_report
from .resid import Analysis, analyse, drifting, half_widths, judged
from .samples import Recording
from .startvalues import data_starts, moved
from .stats import Estimate, Statistics, statistics
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
          input_delay: float, period: float, clock: str) -> tuple[Recording, ...]:
    return tuple(read_recording(b, joints, input_delay, clock, period) for b in bags)


def identify(bags: Sequence[str | os.PathLike[str]], params: str | os.PathLike[str],
             fit: Sequence[str], *, bounds: Mapping[str, tuple[float, float]] | None = None,
             validate: Sequence[str | os.PathLike[str]] = (), output: str | os.PathLike[str]
             | None = None, report: str | os.PathLike[str] | None = None,
             workers: int = 1, scheduler: str | None = None,
             joints: Mapping[str, str] | None = None, input_delay: float = 0.0,
             clock: str = 'stamp', settle: float = 0.0,
             fix: Mapping[str, float] | None = None, speeds: bool = False, starts_count: int = 3, seed: int = 0,
             max_evaluations: int = 40, progress: bool = False) -> IdentifyResult:
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
        Node joint name → the bags' name.
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

    Returns
    -------
    IdentifyResult
        ``finished`` False when Ctrl-C stopped it (the best point so far, written).

    Raises
    ------
    IdentifyError
        Bad input (:mod:`~screwgear_ros.identification.errors`), before any fit starts.

    Examples
    --------
    >>> import screwgear_ros
    >>> result = screwgear_ros.identify(['run_bag'], 'config/realistic.yaml',
    ...                                 ['inertia_table'], output='fitted.yaml')  # doctest: +SKIP
    >>> result.values['inertia_table']  # doctest: +SKIP
    46.1
    """
    began = time.perf_counter()
    base = fixed(base_values(params), fix or {}, fit)
    fitted = fit_parameters(list(fit), base, bounds)
    period = tick_period(base)
    recordings = _read(bags, joints, input_delay, period, clock)
    checks = _read(validate, joints, input_delay, period, clock)
    aliased = check_rate(recordings, fit, mesh_hz(base)) if any(
        name in MESH_PARAMETERS for name in fit) else []
    problem = Problem(base, fitted, recordings, speeds, max(0.0, float(settle)))
    needed = SAMPLES_PER_PARAMETER * len(fitted)
    have = sum(int(np.sum(problem.compared(r))) for r in recordings)
    if have < needed:
        raise TooShortError(f'{have} samples (after losses and --settle) are too short to fit '
                            f'{len(fitted)} parameter(s): at least {needed} samples '
                            f'({needed * period:.3g} s at {1 / period:g} Hz) are needed')
    for recording in (*recordings, *checks):
        # a recorded command the node refuses is refused now; base values at which the
        # model diverges are a large residual to fit from
        with contextlib.suppress(Diverged):
            simulate(base, recording)
    weights = problem.weights
    with Evaluator(problem, weights, workers, scheduler) as evaluator:
        found = data_starts(fitted, recordings)
        outcome = minimize(evaluator, fitted,
                           moved(fitted, starts(fitted, starts_count, seed), found),
                           max_evaluations, progress,
                           first_stage(fitted, list(found)))
        describe = evaluator.describe()
        simulations, sim_seconds = evaluator.simulations, evaluator.sim_seconds
    stats = statistics(fitted, outcome.x, outcome.residual, outcome.jacobian,
                       problem.lag_correlation(outcome.residual),
                       sum(r.reversals for r in recordings))
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
                            start_costs=outcome.start_costs, analysis=analysis, notes=notes)
    if output is not None:
        header = [(f'Fitted by identify to {", ".join(str(b) for b in bags)}: '
                  f'{", ".join(values)}.')]
        if not outcome.finished:
            header.insert(0, 'UNFINISHED: the fit was interrupted; these are the best '
                          'values found so far.')
        result.output = write_fitted(params, output, stats.estimates, header)
    stem = report if report is not None else (
        None if output is None else Path(output).with_name(Path(output).stem + '_report'))
    result.seconds = time.perf_counter() - began
    if stem is not None:
        result.report, result.figure = write_report(
            stem, stats, comparisons, finished=outcome.finished,
            fitted_path=str(output), simulations=simulations, seconds=result.seconds,
            sim_seconds=sim_seconds, workers=describe, speeds=speeds,
            sections=[*analysis.lines(), '## Recordings and starting points', '',
                      *(f'- {note}' for note in notes), ''])
    return result


__all__ = ['SAMPLES_PER_PARAMETER', 'IdentifyResult', 'identify']
