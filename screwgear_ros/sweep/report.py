"""What a sweep leaves for a person: the results files, the summary figure, the status
counts, the failed runs and the worst runs, each with a scenario file that re-runs it."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import yaml

from . import summary
from .model import Sweep
from .store import Store
from .worker import Status

#: How many failed runs the report names.
FAILED_SHOWN = 5


def report(sweep: Sweep, store: Store, done: dict[int, Any], out: Path, *, plot: bool = True,
           quiet: bool = False) -> None:
    """Write the results files (and, with ``plot``, ``out/summary.png``), then print the
    status counts, the first failed runs and the worst runs with their re-run commands.
    Files newer than every run file are kept as they are (a rerun of a finished sweep
    rewrites and redraws nothing).

    Parameters
    ----------
    sweep, store
        The sweep and its results directory.
    done
        The rows of the finished runs by index (nothing is written without one).
    out
        The results directory.
    plot
        Draw ``out/summary.png``.
    quiet
        Write the results files only: no figure, nothing printed but a missing pyarrow.
    """
    if not done:
        return
    kept = store.current(plot and not quiet)
    written = kept if kept is not None else store.write_results(done)
    if not any(p.suffix == '.parquet' for p in written):
        print("sweep: results.parquet needs pyarrow (pip install 'screwgear_ros[sweep]'); "
              'results.csv holds the same table', file=sys.stderr)
    if quiet:
        return
    table = store.table(done)
    metrics = sweep.bundle.metrics
    if plot and kept is not None:
        written.append(out / 'summary.png')
    elif plot:
        try:
            written.append(summary.figure(table, sweep.columns, metrics, bool(sweep.draws),
                                          out / 'summary.png'))
        except (OSError, ValueError) as exc:
            print(f'sweep: summary.png not written: {exc}', file=sys.stderr)
    statuses = {s: table['status'].count(s) for s in dict.fromkeys(table['status'])}
    print('status: ' + ', '.join(f'{n} {s}' for s, n in statuses.items()))
    for k, status in enumerate(table['status']):
        if status != Status.OK:
            print(f'  run {table["index"][k]}: {status}: {table["reason"][k]}')
            if sum(1 for s in table['status'][:k + 1] if s != Status.OK) >= FAILED_SHOWN:
                break
    marked = summary.worst(table, metrics[0])
    if marked:
        print(f'worst runs by {metrics[0]}:')
    for position in marked:
        index = table['index'][position]
        swept = ', '.join(f'{c} = {table[c][position]:.6g}' if isinstance(table[c][position],
                          float) else f'{c} = {table[c][position]}' for c in sweep.columns)
        path = rerun_file(sweep, store, index)
        value = table[metrics[0]][position]
        shown = ('inf (a step never settled)' if value == float('inf')
                 and metrics[0] == 'max_settling_time_s' else f'{value:.6g}')
        print(f'  run {index}: {metrics[0]} = {shown} ({swept})')
        print(f'    run_scenario {path} --record {path.with_suffix("")}_bag')
    print(('up to date, kept: ' if kept is not None else 'wrote ')
          + ', '.join(str(p) for p in written))


def rerun_file(sweep: Sweep, store: Store, index: int) -> Path:
    """Write run ``index`` as a scenario of its own, for ``run_scenario``.

    Parameters
    ----------
    sweep, store
        The sweep and its results directory.
    index
        The run.

    Returns
    -------
    Path
        ``DIR/reruns/run_NNNNNN.yaml``: the run's scenario with every parameter resolved,
        the controller modules beside it.
    """
    spec = sweep.runs[index]
    bundle = sweep.bundle
    directory = store.directory / 'reruns'
    directory.mkdir(exist_ok=True)
    document = yaml.safe_load(bundle.scenario_text) or {}
    document['parameters'] = {**dict(bundle.base), **dict(spec.overrides)}
    document.pop('parameters_file', None)       # its values are in the parameters above
    for name, text in bundle.sources:
        (directory / name).write_text(text, encoding='utf-8')
    path = directory / f'run_{index:06d}.yaml'
    header = (f'# Run {index} of the sweep {sweep.path} (seed {spec.seed}, key {spec.key}):\n'
              f'# its scenario with every parameter resolved. run_scenario {path.name}\n')
    path.write_text(header + yaml.safe_dump(document, sort_keys=False, allow_unicode=True),
                    encoding='utf-8')
    return path


__all__ = ['FAILED_SHOWN', 'report', 'rerun_file']
