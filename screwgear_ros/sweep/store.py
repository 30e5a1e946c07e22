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
        shown = (lambda v: repr(v) if len(repr(v)) < 60 else 'a different text')
        return f'{where.rstrip(".")} is {shown(new)}, was {shown(old)}'
    return None


class Store:
    """The results directory of ``sweep`` (module docstring)."""

    def __init__(self, directory: str | os.PathLike[str], sweep: Sweep) -> None:
        self.directory = Path(directory)
        self.sweep = sweep
        self.runs = self.directory / RUNS

    def open(self) -> dict[int, dict[str, Any]]:
        """Create DIR or check that it holds this sweep; the finished runs by index."""
        resolved = yaml.safe_load(yaml.safe_dump(self.sweep.resolved(), sort_keys=False))
        target = self.directory / RESOLVED
        if target.exists():
            try:
                old = yaml.safe_load(target.read_text(encoding='utf-8'))
            except (OSError, yaml.YAMLError) as exc:
                raise SweepError(f'{target}: cannot read the sweep of this directory: {exc}') \
                    from None
            old, new = dict(old or {}), dict(resolved)
            for where in ('sweep_file', 'parameters_file', 'scenario_file'):
                old.pop(where, None), new.pop(where, None)    # the same files may move
            change = _difference(old, new)
            if change:
                raise SweepError(f'{self.directory} holds another sweep ({target}): '
                                 f'{change}. Use a new --out directory (or delete this one)')
        elif self.directory.exists() and any(self.directory.iterdir()):
            raise SweepError(f'{self.directory} exists and is not a sweep directory (no '
                             f'{RESOLVED}); use a new --out directory')
        try:
            self.runs.mkdir(parents=True, exist_ok=True)
            if not target.exists():
                _write(target, yaml.safe_dump(resolved, sort_keys=False, allow_unicode=True))
        except OSError as exc:
            raise SweepError(f'{self.directory}: cannot write: {exc.strerror or exc}') \
                from None
        return self.finished()

    def finished(self) -> dict[int, dict[str, Any]]:
        keys = {r.index: r.key for r in self.sweep.runs}
        done = {}
        for path in sorted(self.runs.glob('*.json')):
            try:
                row = json.loads(path.read_text(encoding='utf-8'))
                index = int(row['index'])
            except (OSError, ValueError, KeyError, TypeError):
                continue                    # a torn or foreign file: the run is redone
            if keys.get(index) == row.get('key'):
                done[index] = row
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

    def table(self, rows: dict[int, dict[str, Any]]) -> dict[str, list[Any]]:
        """Column → values of the finished runs, in run order: index, seed, the swept
        values, the metrics, status, reason."""
        sweep = self.sweep
        runs = [r for r in sweep.runs if r.index in rows]
        table: dict[str, list[Any]] = {'index': [r.index for r in runs],
                                       'seed': [r.seed for r in runs]}
        for column in sweep.columns:
            number = drawn_column_is_number(sweep, column)
            table[column] = [float(dict(r.swept)[column]) if number
                             else json.dumps(dict(r.swept)[column]) for r in runs]
        for k, name in enumerate(sweep.bundle.metrics):
            table[name] = [float(rows[r.index]['metrics'][k]) for r in runs]
        table['status'] = [rows[r.index]['status'] for r in runs]
        table['reason'] = [rows[r.index]['reason'] for r in runs]
        table['key'] = [r.key for r in runs]
        return table


def failures(rows: Iterable[dict[str, Any]]) -> int:
    return sum(1 for row in rows if row['status'] != Status.OK.value)


__all__ = ['RESOLVED', 'RUNS', 'Store', 'failures']
