"""sweep SWEEP.yaml --out DIR [--workers N] [--scheduler ADDRESS]: many runs of a scenario.

Runs the scenario of a sweep file (README "Sweeps") over its grid and/or Monte Carlo draw,
each run in-process and deterministic, on this process (``--workers 1``, no Dask), an
embedded Dask LocalCluster (default: one worker process per core) or an existing Dask
cluster (``--scheduler tcp://HOST:8786``). Every run is validated before any starts.
Writes DIR/sweep.yaml (the resolved sweep), one file per finished run under DIR/runs/,
then DIR/results.parquet, DIR/results.csv and DIR/summary.png, and prints the worst runs
with the command that re-runs and records one. The same command into the same DIR
resumes: finished runs are skipped.

Exit status: 0 every run has its row (faults, errors and timeouts included, as rows);
1 stopped before every run had one (Ctrl-C, ``--max-runs``): rerun to resume; 2 nothing
was run: a sweep file that cannot be read or is invalid (the message names its line and
entry), a DIR that holds another sweep, an engine that cannot start, with the reason on
stderr and never a traceback.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import EXIT_ERROR, EXIT_OK

#: Stopped before every run had its row (rerun to resume).
EXIT_INCOMPLETE = 1


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog='sweep', description='Run a scenario over a grid and/or a Monte Carlo draw of '
        'parameters (in this process, a Dask LocalCluster or a Dask cluster); results in '
        'DIR/results.parquet, DIR/results.csv, DIR/summary.png. Resumable.')
    parser.add_argument('sweep', help='sweep YAML (README "Sweeps")')
    parser.add_argument('--out', required=True, metavar='DIR', help='results directory '
                        '(new, or one of an earlier run of the same sweep to resume)')
    parser.add_argument('--workers', type=int, metavar='N', help='worker processes of the '
                        'embedded LocalCluster (default: one per core); 1 = in this process, '
                        'no Dask')
    parser.add_argument('--scheduler', metavar='ADDRESS', help='submit to the Dask cluster '
                        'of this scheduler (tcp://HOST:8786) instead')
    parser.add_argument('--max-runs', type=int, metavar='N', help='stop after N more runs '
                        'finish (the rest on a later call)')
    parser.add_argument('--no-plot', action='store_true', help='skip DIR/summary.png')
    args = parser.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        parser.error('--workers takes a number >= 1')
    if args.max_runs is not None and args.max_runs < 1:
        parser.error('--max-runs takes a number >= 1')
    if args.scheduler and args.workers is not None:
        parser.error('--workers is for the embedded cluster; a --scheduler has its own')
    return args


def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    from ..sweep.engine import cores, describe
    from ..sweep.progress import run_pending
    from ..sweep.report import report
    from ..sweep.spec import SweepError, load_sweep
    from ..sweep.store import Store

    try:
        sweep = load_sweep(args.sweep)
        store = Store(args.out, sweep)
        done = store.open()
    except SweepError as exc:
        print(f'sweep: {exc}', file=sys.stderr)
        return EXIT_ERROR
    workers = args.workers or (1 if args.scheduler else cores())
    todo = [r for r in sweep.runs if r.index not in done]
    if args.max_runs is not None:
        todo = todo[:args.max_runs]
    print(f'{args.sweep}: {len(sweep.runs)} runs, {len(done)} finished before, '
          f'{len(todo)} to run on {describe(workers, args.scheduler)}', flush=True)
    interrupted = False
    started = time.perf_counter()
    ran: tuple[float, ...] = ()
    out = Path(args.out)
    if todo:
        try:
            passed = run_pending(sweep, store, done, todo, workers, args.scheduler)
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


def __getattr__(name: str) -> object:
    """``rerun_file`` under its old path, for one release."""
    if name == 'rerun_file':
        import warnings

        from ..sweep import report
        warnings.warn('screwgear_ros.cli.sweep.rerun_file moved to '
                      'screwgear_ros.sweep.report.rerun_file', DeprecationWarning, stacklevel=2)
        return report.rerun_file
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


if __name__ == '__main__':
    sys.exit(main())
