"""sweep SWEEP.yaml --out DIR [--workers N|auto] [--scheduler ADDRESS]: many runs of a scenario.

Runs the scenario of a sweep file (docs/sweeps.md) over its grid and/or Monte Carlo draw,
each run in-process and deterministic, on this process (``--workers 1``, no Dask), an
embedded Dask LocalCluster or an existing Dask cluster (``--scheduler tcp://HOST:8786``).
The default, ``--workers auto``, takes the cores free now (affinity less the load
average): one, here, on a busy machine. A sweep of more than ``--allow-runs`` runs is
refused with its count before any run is built. Every run is validated before any starts
(a cluster starts meanwhile, once the sweep file has said how many runs it has); a sweep
with nothing left to run starts no cluster.
Writes DIR/sweep.yaml (the resolved sweep), one file per finished run under DIR/runs/,
then DIR/results.parquet, DIR/results.csv and DIR/summary.png, and prints the worst runs
with the command that re-runs and records one. The same command into the same DIR
resumes: finished runs are skipped.

Exit status: 0 every run has its row (faults, errors and timeouts included, as rows);
1 stopped before every run had one (Ctrl-C, ``--max-runs``): rerun to resume; 2 nothing
was run: a sweep file that cannot be read or is invalid (the message names its line and
entry), a DIR that holds another sweep, an engine that cannot start, with the reason on
stderr and never a traceback; 130 Ctrl-C before any run started (while validating).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from . import EXIT_ERROR, EXIT_OK, interruptible

if TYPE_CHECKING:
    from ..sweep.early import EarlyCluster

#: --workers: the cores free now.
AUTO = 'auto'
#: Sweeps of this many runs or more say so before they are validated.
ANNOUNCE = 10_000

#: Stopped before every run had its row (rerun to resume).
EXIT_INCOMPLETE = 1


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog='sweep', description='Run a scenario over a grid and/or a Monte Carlo draw of '
        'parameters (in this process, a Dask LocalCluster or a Dask cluster); results in '
        'DIR/results.parquet, DIR/results.csv, DIR/summary.png. Resumable.')
    parser.add_argument('sweep', help='sweep YAML (docs/sweeps.md)')
    parser.add_argument('--out', required=True, metavar='DIR', help='results directory '
                        '(new, or one of an earlier run of the same sweep to resume)')
    parser.add_argument('--workers', type=_workers, default=AUTO, metavar='N|auto',
                        help='worker processes of the embedded LocalCluster; 1 = in this '
                        'process, no Dask; auto (default): the cores free now (affinity '
                        'less the load average), 1 on a busy machine')
    parser.add_argument('--scheduler', metavar='ADDRESS', help='submit to the Dask cluster '
                        'of this scheduler (tcp://HOST:8786) instead')
    parser.add_argument('--max-runs', type=int, metavar='N', help='stop after N more runs '
                        'finish (the rest on a later call)')
    parser.add_argument('--allow-runs', type=int, metavar='N',
                        help='resolve a sweep of up to N runs (default: '
                        'screwgear_ros.sweep.spec.RUN_LIMIT, 100,000); a larger one is '
                        'refused with its run count before anything is built')
    parser.add_argument('--no-plot', action='store_true', help='skip DIR/summary.png')
    args = parser.parse_args(argv)
    if args.max_runs is not None and args.max_runs < 1:
        parser.error('--max-runs takes a number >= 1')
    if args.allow_runs is not None and args.allow_runs < 1:
        parser.error('--allow-runs takes a number >= 1')
    if args.scheduler and args.workers != AUTO:
        parser.error('--workers is for the embedded cluster; a --scheduler has its own')
    return args


def _workers(text: str) -> str | int:
    if text == AUTO:
        return AUTO
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r}: a number >= 1, or auto') from None
    if value < 1:
        raise argparse.ArgumentTypeError('a number >= 1, or auto')
    return value


def _announce(total: int, simulated: float) -> None:
    if total >= ANNOUNCE:
        print(f'{total:,} runs, {simulated:.3g} s of simulation in all: validating every run '
              'before any starts', flush=True)


@interruptible('sweep', 'nothing was run')
def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    from ..sweep.early import EarlyCluster

    early = EarlyCluster(None if args.workers == AUTO else int(args.workers), args.scheduler,
                         args.max_runs, _announce)
    try:
        return _sweep(args, early)
    finally:
        early.close()


def _sweep(args: argparse.Namespace, early: EarlyCluster) -> int:
    from ..sweep.engine import describe
    from ..sweep.progress import run_pending
    from ..sweep.report import report
    from ..sweep.spec import RUN_LIMIT, SweepError, load_sweep
    from ..sweep.store import Store, finished_keys

    try:
        finished = finished_keys(args.out)
        early.finished = len(finished)
        sweep = load_sweep(args.sweep, limit=args.allow_runs or RUN_LIMIT,
                           announce=early, validated=finished)
        store = Store(args.out, sweep)
        done = store.open()
    except SweepError as exc:
        print(f'sweep: {exc}', file=sys.stderr)
        return EXIT_ERROR
    for path, why in store.damaged:
        print(f'sweep: {path} is damaged ({why}): its run is run again', file=sys.stderr)
    todo = [r for r in sweep.runs if r.index not in done]
    if args.max_runs is not None:
        todo = todo[:args.max_runs]
    chosen = early.workers(len(todo))
    workers = chosen.count
    if todo and not args.scheduler and args.workers == AUTO:
        print(f'--workers auto: {workers} ({chosen.why})', flush=True)
    cluster = early.take(workers, len(todo))
    print(f'{args.sweep}: {len(sweep.runs)} runs, {len(done)} finished before, '
          f'{len(todo)} to run' + (f' on {describe(workers, args.scheduler)}' if todo
                                   else ''), flush=True)
    interrupted = False
    started = time.perf_counter()
    ran: tuple[float, ...] = ()
    out = Path(args.out)
    if todo:
        try:
            passed = run_pending(sweep, store, done, todo, workers, args.scheduler,
                                 cluster)
            interrupted, ran = passed.interrupted, passed.wall_times
        except Exception as exc:  # noqa: BLE001 - an engine that fails: reason, no traceback
            print(f'sweep: the engine failed ({describe(workers, args.scheduler)}): '
                  f'{type(exc).__name__}: {exc}; {len(done)} runs are kept in {args.out}',
                  file=sys.stderr)
            report(sweep, store, done, out, quiet=True)
            return EXIT_ERROR
    wall = time.perf_counter() - started
    if ran:
        print(f'{len(ran)} runs in {wall:.1f} s of wall time ({wall / len(ran):.3f} s a run; '
              f'each run {sum(ran) / len(ran):.3f} s on its worker)')
    report(sweep, store, done, out, plot=not args.no_plot)
    left = len(sweep.runs) - len(done)
    if left:
        why = 'interrupted' if interrupted else f'stopped after --max-runs {args.max_runs}'
        print(f'{why}: {len(done)} of {len(sweep.runs)} runs finished; the same command '
              f'resumes with the {left} left', file=sys.stderr)
        return EXIT_INCOMPLETE
    return EXIT_OK


if __name__ == '__main__':
    sys.exit(main())
