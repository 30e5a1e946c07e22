"""A sweep's results directory.

``DIR/sweep.yaml`` is the resolved sweep (every drawn value); a later sweep into the same
DIR must resolve to the same document, else it is refused with the entry that differs.
``DIR/runs/NNNNNN.json`` holds one finished run each, written whole (write, then rename)
the moment it is back: an interrupted sweep keeps every run that finished, and a rerun
skips the runs whose file is there with the same key. ``results.parquet`` and
``results.csv`` are made from those files, in run order.
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml

from .model import Sweep, SweepError, drawn_column_is_number
from .worker import Outcome, Status

RESOLVED = 'sweep.yaml'
RUNS = 'runs'
RESULTS = 'results'


#: The resolved sweep holds every run's values and is read on every rerun: libyaml's
#: parser and emitter where PyYAML was built with them (the same documents, much faster:
#: ``benchmarks/bench_sweep_example.py``'s rerun), PyYAML's own otherwise.
_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_DUMPER = getattr(yaml, 'CSafeDumper', yaml.SafeDumper)


def _dump(document: Any) -> str:
    return yaml.dump(document, Dumper=_DUMPER, sort_keys=False, allow_unicode=True)


def _write(path: Path, text: str) -> None:
    part = path.with_name(path.name + '.part')
    part.write_text(text, encoding='utf-8')
    os.replace(part, path)


def _difference(old: Any, new: Any, where: str = '') -> str | None:
    """The first entry where two resolved documents differ, as a sentence."""
    if isinstance(old, dict) and isinstance(new, dict):
        for key in [*old, *(k for k in new if k not in old)]:
            if key not in new:
                return f'{where}{key} is gone'
            if key not in old:
                return f'{where}{key} is new'
            found = _difference(old[key], new[key], f'{where}{key}.')
            if found:
                return found
        return None
    if isinstance(old, list) and isinstance(new, list):
        if len(old) != len(new):
            return f'{where.rstrip(".")} has {len(new)} entries, was {len(old)}'
        for k, (a, b) in enumerate(zip(old, new, strict=True)):
            found = _difference(a, b, f'{where}{k}.')
            if found:
                return found
        return None
    if old != new and not (isinstance(old, float) and isinstance(new, float)
                           and math.isnan(old) and math.isnan(new)):
        if isinstance(old, str) and isinstance(new, str) and len(repr(old) + repr(new)) >= 60:
            return _text_difference(where.rstrip('.'), old, new)
        return f'{where.rstrip(".")} is {new!r}, was {old!r}'
    return None


def _text_difference(what: str, old: str, new: str) -> str:
    r"""Where two texts (a controller module, a scenario) first differ: the line, and
    what it says now and said before (each cut to 70 characters).

    Examples
    --------
    >>> print(_text_difference('controller_sources.pid.py', 'a\nkp = 1\n', 'a\nkp = 2\n'))
    controller_sources.pid.py changed at line 2: now 'kp = 2', was 'kp = 1'
    """
    before, after = old.splitlines(), new.splitlines()
    for line, (a, b) in enumerate(zip(before, after, strict=False), start=1):
        if a != b:
            return f'{what} changed at line {line}: now {b[:70]!r}, was {a[:70]!r}'
    line = min(len(before), len(after)) + 1
    if len(after) > len(before):
        return f'{what} has new lines from line {line} on: {after[line - 1][:70]!r} ...'
    if len(after) < len(before):
        return f'{what} lost its lines from line {line} on: {before[line - 1][:70]!r} ...'
    return f'{what} changed in its line endings or trailing blanks'


def finished_keys(directory: str | os.PathLike[str]) -> frozenset[str]:
    """The keys of the run files in a results directory, read leniently (what cannot be
    read is left out): the runs a rerun need not validate again.

    Examples
    --------
    >>> finished_keys('/nonexistent/results')
    frozenset()
    """
    keys = set()
    for path in Path(directory, RUNS).glob('*.json'):
        row, _ = _read_row(path)
        if isinstance(row, dict) and isinstance(row.get('key'), str):
            keys.add(row['key'])
    return frozenset(keys)


def _read_row(path: Path) -> tuple[Any, str | None]:
    """A run file's JSON document, or None and why it is not one."""
    try:
        return json.loads(path.read_text(encoding='utf-8')), None
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        return None, f'not a JSON row ({type(exc).__name__})'


def _change(old: dict[str, Any], new: dict[str, Any]) -> str | None:
    """The first entry where two resolved sweeps differ, but for where their files lie
    (the same files may move)."""
    old, new = dict(old), dict(new)
    for where in ('sweep_file', 'parameters_file', 'scenario_file'):
        old.pop(where, None), new.pop(where, None)
    return _difference(old, new)


class Store:
    """The results directory of ``sweep`` (module docstring)."""

    def __init__(self, directory: str | os.PathLike[str], sweep: Sweep) -> None:
        self.directory = Path(directory)
        self.sweep = sweep
        self.runs = self.directory / RUNS
        self.damaged: list[tuple[Path, str]] = []   # run files found damaged by finished()

    def open(self) -> dict[int, dict[str, Any]]:
        """Create DIR or check that it holds this sweep; the finished runs by index."""
        text = _dump(self.sweep.resolved())
        target = self.directory / RESOLVED
        if self.directory.exists() and not self.directory.is_dir():
            raise SweepError(f'{self.directory} is not a directory; --out names a results '
                             'directory (new, or one of an earlier run of this sweep)')
        if target.exists():
            try:
                written = target.read_text(encoding='utf-8')
                # the same text: this sweep, written by this program (no parse needed)
                same = written == text
                old = None if same else yaml.load(written, Loader=_LOADER)
            except (OSError, UnicodeDecodeError, yaml.YAMLError, RecursionError) as exc:
                why = 'nested too deeply' if isinstance(exc, RecursionError) else \
                    str(exc).splitlines()[0]
                raise SweepError(f'{target}: cannot read the sweep of this directory: '
                                 f'{why}') from None
            if not same:
                if not isinstance(old, dict):
                    raise SweepError(f'{self.directory} holds no sweep of this program '
                                     f'({target} holds {type(old).__name__} '
                                     f'{str(old)[:40]!r}, not a resolved sweep); use a new '
                                     '--out directory')
                change = _change(old, yaml.load(text, Loader=_LOADER))
                if change:
                    raise SweepError(f'{self.directory} holds another sweep ({target}): '
                                     f'{change}. Use a new --out directory (or delete this '
                                     'one)')
        elif self.directory.exists() and any(self.directory.iterdir()):
            raise SweepError(f'{self.directory} exists and is not a sweep directory (no '
                             f'{RESOLVED}); use a new --out directory')
        try:
            self.runs.mkdir(parents=True, exist_ok=True)
            if not target.exists():
                _write(target, text)
        except OSError as exc:
            raise SweepError(f'{self.directory}: cannot write: {exc.strerror or exc}') \
                from None
        return self.finished()

    def finished(self) -> dict[int, dict[str, Any]]:
        """The finished runs by index: each run file that holds a whole row of this
        sweep's run of its name. A damaged one (torn, edited, of another program) is
        left for its run to redo it, and listed in :attr:`damaged`."""
        runs = {r.index: r for r in self.sweep.runs}
        metrics = len(self.sweep.bundle.metrics)
        done: dict[int, dict[str, Any]] = {}
        self.damaged = []
        for path in sorted(self.runs.glob('*.json')):
            row, why = _read_row(path)
            if why is None:
                why = damage(row, metrics)
            if why is None:
                run = runs.get(row['index'])
                if run is None or path.name != f'{run.index:06d}.json':
                    why = f'names run {row["index"]}, not a run of this sweep by its name'
                elif run.key != row['key']:
                    continue                # a run of another sweep's key: redone silently
            if why is not None:
                self.damaged.append((path, why))
                continue
            done[row['index']] = row
        return done

    def add(self, outcome: Outcome) -> dict[str, Any]:
        row = {**outcome.row(), 'wall_time': outcome.wall_time}
        _write(self.runs / f'{outcome.index:06d}.json', json.dumps(row))
        return row

    def write_results(self, rows: dict[int, dict[str, Any]]) -> list[Path]:
        """results.parquet (if pyarrow is there) and results.csv of the finished runs,
        in run order; the files written."""
        table = self.table(rows)
        written = [self.directory / f'{RESULTS}.csv']
        part = written[0].with_suffix('.csv.part')
        with open(part, 'w', newline='', encoding='utf-8') as stream:
            writer = csv.writer(stream)
            writer.writerow(list(table))
            writer.writerows(zip(*table.values(), strict=True))
        os.replace(part, written[0])
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            return written
        target = self.directory / f'{RESULTS}.parquet'
        part = target.with_suffix('.parquet.part')
        pq.write_table(pa.table(table), part)
        os.replace(part, target)
        return [target, *written]

    def current(self, plot: bool) -> list[Path] | None:
        """The results files (with summary.png if ``plot``) when each is newer than every
        run file, so that they hold every finished run; else None."""
        names = [f'{RESULTS}.csv', *((f'{RESULTS}.parquet',) if _has_pyarrow() else ()),
                 *(('summary.png',) if plot else ())]
        files = [self.directory / name for name in names]
        try:
            oldest = min(f.stat().st_mtime_ns for f in files)
            newest = max((f.stat().st_mtime_ns for f in self.runs.glob('*.json')), default=0)
        except OSError:
            return None
        return [f for f in files if f.suffix != '.png'] if oldest > newest else None

    def table(self, rows: dict[int, dict[str, Any]]) -> dict[str, list[Any]]:
        """Column → values of the finished runs, in run order: index, seed, the swept
        values (a scaled parameter: its factor ``NAME_scale`` and the value it gave,
        ``NAME``), the metrics, status, reason."""
        sweep = self.sweep
        runs = [r for r in sweep.runs if r.index in rows]
        table: dict[str, list[Any]] = {'index': [r.index for r in runs],
                                       'seed': [r.seed for r in runs]}
        for column in sweep.columns:
            number = drawn_column_is_number(sweep, column)
            table[column] = [float(dict(r.swept)[column]) if number
                             else json.dumps(dict(r.swept)[column]) for r in runs]
        for axis in (*sweep.grid, *sweep.draws):
            if axis.column != axis.name and not axis.shared:   # the value it gave
                values = [dict(r.overrides)[axis.name] for r in runs]
                table[axis.name] = [float(v) if isinstance(v, (int, float))
                                    else json.dumps(v) for v in values]
        for k, name in enumerate(sweep.bundle.metrics):
            table[name] = [float(rows[r.index]['metrics'][k]) for r in runs]
        table['status'] = [rows[r.index]['status'] for r in runs]
        table['reason'] = [rows[r.index]['reason'] for r in runs]
        table['key'] = [r.key for r in runs]
        return table


def _has_pyarrow() -> bool:
    import importlib.util

    try:
        return importlib.util.find_spec('pyarrow') is not None
    except (ImportError, ValueError):
        return False


def damage(row: Any, metrics: int) -> str | None:
    """What is wrong with a run file's row (None: a whole row of ``metrics`` metrics)."""
    if not isinstance(row, dict):
        return f'holds {type(row).__name__}, not a row'
    for name, kind in (('index', int), ('key', str), ('status', str), ('reason', str),
                       ('metrics', list)):
        if name not in row:
            return f'has no {name!r}'
        if not isinstance(row[name], kind) or isinstance(row[name], bool):
            return f'{name!r} is {type(row[name]).__name__}, not {kind.__name__}'
    if row['status'] not in {s.value for s in Status}:
        return f'status {row["status"][:20]!r} is none of {", ".join(s.value for s in Status)}'
    values = row['metrics']
    if len(values) != metrics or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return f'metrics is not a list of {metrics} numbers'
    return None


def failures(rows: Iterable[dict[str, Any]]) -> int:
    return sum(1 for row in rows if row['status'] != Status.OK.value)


__all__ = ['RESOLVED', 'RUNS', 'Store', 'damage', 'failures', 'finished_keys']
