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
from typing import Any

import yaml

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
    from ..sweep.engine import cores, describe, outcomes
    from ..sweep.spec import SweepError, load_sweep
    from ..sweep.store import Store, failures

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
    ran: list[float] = []
    if todo:
        try:
            interrupted = _run(sweep, store, done, todo, workers, args.scheduler, ran,
                               outcomes, failures)
        except Exception as exc:  # noqa: BLE001 - an engine that fails: reason, no traceback
            print(f'sweep: the engine failed ({describe(workers, args.scheduler)}): '
                  f'{type(exc).__name__}: {exc}; {len(done)} runs are kept in {args.out}',
                  file=sys.stderr)
            _results(sweep, store, done, args, quiet=True)
            return EXIT_ERROR
    wall = time.perf_counter() - started
    if ran:
        print(f'{len(ran)} runs in {wall:.1f} s of wall time ({wall / len(ran):.3f} s a run; '
              f'each run {sum(ran) / len(ran):.3f} s on its worker)')
    _results(sweep, store, done, args)
    left = len(sweep.runs) - len(done)
    if left:
        why = 'interrupted' if interrupted else f'stopped after --max-runs {args.max_runs}'
        print(f'{why}: {len(done)} of {len(sweep.runs)} runs finished; the same command '
              f'resumes with the {left} left', file=sys.stderr)
        return EXIT_INCOMPLETE
    return EXIT_OK


def _run(sweep: Any, store: Any, done: dict[int, Any], todo: list[Any], workers: int,
         scheduler: str | None, ran: list[float], outcomes: Any, failures: Any) -> bool:
    """Run ``todo``, each finished run written at once; True if interrupted (Ctrl-C)."""
    from tqdm import tqdm

    failed = failures(done.values())
    stream = outcomes(sweep.bundle, todo, workers, scheduler)
    bar = tqdm(total=len(sweep.runs), initial=len(done), unit='run', dynamic_ncols=True,
               desc='sweep', file=sys.stderr)
    bar.set_postfix(failures=failed)
    try:
        for outcome in stream:
            done[outcome.index] = store.add(outcome)
            if outcome.wall_time == outcome.wall_time:      # NaN: a worker lost under it
                ran.append(outcome.wall_time)
            failed += outcome.status.value != 'ok'
            bar.set_postfix(failures=failed, refresh=False)
            bar.update(1)
    except KeyboardInterrupt:
        return True
    finally:
        bar.close()
        close = getattr(stream, 'close', None)
        if close is not None:
            close()
    return False


def _results(sweep: Any, store: Any, done: dict[int, Any], args: argparse.Namespace,
             quiet: bool = False) -> None:
    """The results files, the summary figure and the worst runs."""
    from ..sweep import summary

    if not done:
        return
    written = store.write_results(done)
    if not any(p.suffix == '.parquet' for p in written):
        print("sweep: results.parquet needs pyarrow (pip install 'screwgear_ros[sweep]'); "
              'results.csv holds the same table', file=sys.stderr)
    if quiet:
        return
    table = store.table(done)
    metrics = sweep.bundle.metrics
    if not args.no_plot:
        try:
            written.append(summary.figure(table, sweep.columns, metrics, bool(sweep.draws),
                                          Path(args.out) / 'summary.png'))
        except (OSError, ValueError) as exc:
            print(f'sweep: summary.png not written: {exc}', file=sys.stderr)
    statuses = {s: table['status'].count(s) for s in dict.fromkeys(table['status'])}
    print('status: ' + ', '.join(f'{n} {s}' for s, n in statuses.items()))
    for k, status in enumerate(table['status']):
        if status != 'ok':
            print(f'  run {table["index"][k]}: {status}: {table["reason"][k]}')
            if sum(1 for s in table['status'][:k + 1] if s != 'ok') >= 5:
                break
    marked = summary.worst(table, metrics[0])
    if marked:
        print(f'worst runs by {metrics[0]}:')
    for position in marked:
        index = table['index'][position]
        swept = ', '.join(f'{c} = {table[c][position]:.6g}' if isinstance(table[c][position],
                          float) else f'{c} = {table[c][position]}' for c in sweep.columns)
        path = rerun_file(sweep, store, index)
        print(f'  run {index}: {metrics[0]} = {table[metrics[0]][position]:.6g} ({swept})')
        print(f'    run_scenario {path} --record {path.with_suffix("")}_bag')
    print('wrote ' + ', '.join(str(p) for p in written))


def rerun_file(sweep: Any, store: Any, index: int) -> Path:
    """DIR/reruns/run_NNNNNN.yaml: run ``index`` as a scenario of its own (its parameters
    resolved, the controller modules beside it), for run_scenario."""
    spec = sweep.runs[index]
    bundle = sweep.bundle
    directory = store.directory / 'reruns'
    directory.mkdir(exist_ok=True)
    document = yaml.safe_load(bundle.scenario_text) or {}
    document['parameters'] = {**dict(bundle.base), **dict(spec.overrides)}
    for name, text in bundle.sources:
        (directory / name).write_text(text, encoding='utf-8')
    path = directory / f'run_{index:06d}.yaml'
    header = (f'# Run {index} of the sweep {sweep.path} (seed {spec.seed}, key {spec.key}):\n'
              f'# its scenario with every parameter resolved. run_scenario {path.name}\n')
    path.write_text(header + yaml.safe_dump(document, sort_keys=False, allow_unicode=True),
                    encoding='utf-8')
    return path


if __name__ == '__main__':
    sys.exit(main())
