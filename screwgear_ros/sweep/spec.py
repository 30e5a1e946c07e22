"""Sweep files: many runs of one scenario over a grid and/or a Monte Carlo draw.

:func:`load_sweep` reads a sweep file, reads the files it names (on the client: their
contents, not their paths, go to the workers) and resolves every run
(:func:`~screwgear_ros.sweep.resolve.resolve_runs`): its index, its seed (derived from the
sweep seed and the index alone), its parameter values and the digest of everything it
depends on. Every run is validated before any starts, by the node's own rules; an error is
a :class:`~screwgear_ros.sweep.model.SweepError` naming the file, the line and the entry.
No Dask here: this module runs anywhere the package does.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

import yaml

from ..inprocess.metrics import Metrics
from ..params.declarations import declared
from ..params.table import SimSettings, TableParams
from ..params.yaml_reader import YamlReader
from ..sim.parameter_set import default_values
from . import model
from .inputs import (
    NODE_ONLY,
    base_values,
    controller_sources,
    explicit_parameters,
    plain_value,
    scenario_of,
)
from .model import Sweep, SweepError, plain
from .resolve import resolve_runs, run_count

#: The top-level keys of a sweep file.
KEYS = ('parameters', 'scenario', 'metrics', 'time_limit', 'grid', 'monte_carlo')
MONTE_CARLO_KEYS = ('count', 'seed', 'parameters')
#: The metrics a sweep can keep: the flat names of a run's metrics.
METRICS = tuple(Metrics(0.0, None, (), (), (0.0, 0.0), None, 0).as_dict())
#: Default wall-time limit of one run, s.
TIME_LIMIT = 300.0
#: Parameters that may be swept (read-only ones too: a run sets them at its start).
SWEEPABLE = tuple(p.name for cls in (TableParams, SimSettings) for p in declared(cls)
                  if p.name not in NODE_ONLY)
#: The most runs a sweep resolves unless its caller allows more (each run is resolved,
#: validated and held before any starts: about a kB and 0.1 ms to 1 ms each).
RUN_LIMIT = 100_000


def load_sweep(path: str | Path, *, limit: int | None = RUN_LIMIT,
               announce: Callable[[int, float], None] | None = None,
               validated: Collection[str] = frozenset()) -> Sweep:
    """Read, resolve and validate a sweep file.

    Parameters
    ----------
    path
        The sweep file.
    limit
        The most runs to resolve; a sweep of more is refused with its run count before
        any is resolved (None: no limit).
    announce
        Called with the run count and the simulated seconds of all runs once they are
        known, before the runs are resolved and validated.
    validated
        Keys of runs validated before (the finished runs of a results directory,
        :func:`~screwgear_ros.sweep.store.finished_keys`): not validated again.

    Returns
    -------
    Sweep
        Every run, resolved and validated.

    Raises
    ------
    SweepError
        What is wrong, with the file, the line and the entry; never another exception
        for what a file holds.

    Examples
    --------
    >>> load_sweep('docs/examples/tolerance_sweep.yaml').count  # doctest: +SKIP
    300
    """
    path = Path(path)
    try:
        reader = YamlReader.open(path, SweepError)
    except (yaml.YAMLError, RecursionError, ValueError) as exc:
        if isinstance(exc, SweepError):
            raise
        raise SweepError(f'{path}: {_unreadable(path, exc)}') from None
    try:
        return _load(reader, path, limit, announce, validated)
    except RecursionError:
        raise SweepError(f'{path}: nested too deeply') from None


def _load(reader: YamlReader, path: Path, limit: int | None,
          announce: Callable[[int, float], None] | None,
          validated: Collection[str]) -> Sweep:
    if reader.root is None:
        raise SweepError(f'{path}: empty; a sweep needs a scenario, metrics and a grid or '
                         'monte_carlo')
    top = reader.mapping(reader.root, 'a sweep')
    reader.known(top, KEYS, 'sweep key')
    for needed in ('scenario', 'metrics'):
        if needed not in top:
            raise reader.error(reader.root, f'a sweep needs {needed!r}')
    if 'grid' not in top and 'monte_carlo' not in top:
        raise reader.error(reader.root, "a sweep needs a 'grid', a 'monte_carlo' or both")
    here = path.resolve().parent

    # the files it names, read here (their contents go to the workers)
    base: dict[str, Any] = {}
    base_file = None
    if 'parameters' in top:
        base, base_file = base_values(reader, top['parameters'][1], here)
    scenario, scenario_file, scenario_text = scenario_of(reader, top['scenario'][1], here)
    values = dict(scenario.values)
    base = {**base, **{k: values[k] for k in explicit_parameters(scenario_text)}}
    try:
        sources = controller_sources(scenario, scenario_file.resolve().parent)
    except (OSError, UnicodeDecodeError) as exc:
        raise reader.error(top['scenario'][1], f'scenario: its controller module cannot '
                           f'be read: {exc}') from None

    metrics = _metrics(reader, top['metrics'][1])
    time_limit = TIME_LIMIT
    if 'time_limit' in top:
        time_limit = reader.number(top['time_limit'][1], 'time_limit (s of wall time per '
                                   'run)', low=0.0, strict=True)
    grid = _grid(reader, top['grid'][1]) if 'grid' in top else ()
    count, seed = 1, 0
    draws: tuple[model.Axis, ...] = ()
    if 'monte_carlo' in top:
        count, seed, draws = _monte_carlo(reader, top['monte_carlo'][1])
    names = [a.name for a in (*grid, *draws)]
    for axis in (*grid, *draws):
        if names.count(axis.name) > 1:
            raise reader.error(axis.line or None,
                               f'{axis.name} is swept twice (grid and monte_carlo)')
        if axis.scale:
            _scalable(reader, axis, base.get(axis.name, default_values().get(axis.name)))

    total = run_count(grid, count)
    simulated = float(scenario.duration) * min(total, 10 ** 300)     # no float overflow
    if limit is not None and total > limit:
        sizes = ' x '.join(str(len(a.values)) for a in grid) or '1'
        raise SweepError(f'{path}: {total:,} runs (grid {sizes}, {count:,} draws each; '
                         f'{simulated:.3g} s of simulation in all): more than the limit of '
                         f'{limit:,} runs; a smaller sweep, or allow it (sweep '
                         f'--allow-runs {total})')
    if announce is not None:
        announce(total, simulated)
    bundle = model.Bundle(scenario_file.name, scenario_text, sources,
                          tuple(plain(base).items()), metrics, time_limit)
    runs = resolve_runs(reader, bundle, scenario, grid, draws, count, seed, validated)
    return Sweep(str(path), bundle, grid, draws, count, seed, tuple(runs), base_file,
                 str(scenario_file.resolve()))


def _unreadable(path: Path, exc: BaseException) -> str:
    """Why the YAML of ``path`` cannot be composed, with its line where the reader
    knows it (a control character is found before any line is composed)."""
    if isinstance(exc, RecursionError):
        return 'nested too deeply'
    if isinstance(exc, yaml.reader.ReaderError):
        try:
            text = path.read_text(encoding='utf-8')
            line = f'line {text[:exc.position].count(chr(10)) + 1}: '
        except (OSError, UnicodeDecodeError):
            line = ''
        character = chr(exc.character) if isinstance(exc.character, int) else exc.character
        return (f'{line}not valid YAML: character {character!r} is not allowed '
                '(a control character)')
    return f'not valid YAML: {str(exc).splitlines()[0]}'


def _scalable(reader: YamlReader, axis: model.Axis, base: Any) -> None:
    """A scaled axis multiplies a number or a list of numbers; nothing else scales."""
    number = (lambda v: isinstance(v, (int, float)) and not isinstance(v, bool))
    if number(base) or (isinstance(base, (list, tuple)) and all(map(number, base))):
        return
    raise reader.error(axis.line, f'{axis.name}: scale multiplies a number or a list of '
                       f'numbers; {axis.name} is {base!r}: give its values instead')


def _metrics(reader: YamlReader, node: yaml.Node) -> tuple[str, ...]:
    value = reader.value(node)
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not value:
        raise reader.error(node, f'metrics is a list of metric names (known: '
                           f'{", ".join(METRICS)})')
    for item, name in zip(node.value if isinstance(node, yaml.SequenceNode) else [node],
                          value, strict=True):
        if name not in METRICS:
            raise reader.error(item, f'unknown metric {name!r} (known: {", ".join(METRICS)})')
    if len(set(value)) != len(value):
        raise reader.error(node, 'a metric is named twice')
    return tuple(value)


def _parameter_name(reader: YamlReader, key: yaml.Node, name: str) -> None:
    if name in NODE_ONLY:
        raise reader.error(key, f'{name} is a setting of the node process (pacing, clock, '
                           'lockstep, recording): it has no meaning for an in-process run')
    if name not in SWEEPABLE:
        raise reader.error(key, f'{name!r} is not a parameter of table_sim (the parameter '
                           'table of docs/parameters.md names them)')


def _scaled(reader: YamlReader, node: yaml.Node, what: str) -> tuple[bool, yaml.Node]:
    """(scale?, the node of the values): ``{scale: ...}`` multiplies the base value."""
    if isinstance(node, yaml.MappingNode):
        entries = reader.mapping(node, what)
        if 'scale' in entries:
            if len(entries) != 1:
                raise reader.error(node, f"{what}: 'scale' takes the whole entry "
                                   '({scale: ...})')
            return True, entries['scale'][1]
    return False, node


def _grid(reader: YamlReader, node: yaml.Node) -> tuple[model.Axis, ...]:
    axes = []
    for name, (key, value) in reader.mapping(node, 'grid').items():
        _parameter_name(reader, key, name)
        scale, values_node = _scaled(reader, value, f'grid {name}')
        values = reader.value(values_node)
        if not isinstance(values_node, yaml.SequenceNode) or not values:
            raise reader.error(values_node, f'grid {name}: a non-empty list of values')
        for item, value in zip(values_node.value, values, strict=True):
            if scale:
                reader.number(item, f'grid {name}: a scale factor')
            elif not plain_value(value):
                raise reader.error(item, f'grid {name}: {value!r} is not a parameter value '
                                   '(a number, a string, a bool or a list of them)')
        axes.append(model.Axis(name, key.start_mark.line + 1, scale, tuple(values)))
    if not axes:
        raise reader.error(node, 'grid: name at least one parameter with its values')
    return tuple(axes)


def _monte_carlo(reader: YamlReader,
                 node: yaml.Node) -> tuple[int, int, tuple[model.Axis, ...]]:
    entries = reader.mapping(node, 'monte_carlo')
    reader.known(entries, MONTE_CARLO_KEYS, 'monte_carlo key')
    for needed in ('count', 'parameters'):
        if needed not in entries:
            raise reader.error(node, f'monte_carlo needs {needed!r}')
    count = reader.value(entries['count'][1])
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise reader.error(entries['count'][1], f'monte_carlo count is a whole number >= 1, '
                           f'not {count!r}')
    seed = reader.value(entries['seed'][1]) if 'seed' in entries else 0
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise reader.error(entries['seed'][1], f'monte_carlo seed is a whole number >= 0, '
                           f'not {seed!r}')
    axes = []
    for name, (key, value) in reader.mapping(entries['parameters'][1],
                                             'monte_carlo parameters').items():
        _parameter_name(reader, key, name)
        scale, law_node = _scaled(reader, value, f'monte_carlo {name}')
        laws = reader.mapping(law_node, f'monte_carlo {name}')
        known = tuple(law.value for law in model.Law)
        if len(laws) != 1 or next(iter(laws)) not in known:
            raise reader.error(law_node, f'monte_carlo {name}: one distribution of '
                               f'{", ".join(known)}, e.g. {{uniform: [low, high]}}')
        (law_name, (_, args_node)), = laws.items()
        law = model.Law(law_name)
        expected = model.ARGUMENTS[law]
        if not isinstance(args_node, yaml.SequenceNode) or len(args_node.value) != len(expected):
            raise reader.error(args_node, f'monte_carlo {name}: {law.value} takes '
                               f'[{", ".join(expected)}]')
        args = tuple(reader.number(n, f'monte_carlo {name}: {arg}')
                     for n, arg in zip(args_node.value, expected, strict=True))
        if law is not model.Law.UNIFORM and args[1] <= 0.0:
            raise reader.error(args_node, f'monte_carlo {name}: std must be > 0')
        low_high = args[-2:] if law is not model.Law.NORMAL else None
        if low_high is not None and not low_high[0] < low_high[1]:
            raise reader.error(args_node, f'monte_carlo {name}: low must be below high')
        _drawable(reader, args_node, f'monte_carlo {name}', law, args)
        axes.append(model.Axis(name, key.start_mark.line + 1, scale,
                               draw=model.Draw(law, args)))
    if not axes:
        raise reader.error(entries['parameters'][1], 'monte_carlo parameters: name at least '
                           'one parameter with its distribution')
    return count, seed, tuple(axes)


def _drawable(reader: YamlReader, node: yaml.Node, what: str, law: model.Law,
              args: tuple[float, ...]) -> None:
    """Refuse a draw whose values cannot be finite floats: a range or spread wider than
    the largest float, a truncated window so far out that it has no σ count."""
    if law is model.Law.UNIFORM and not math.isfinite(args[1] - args[0]):
        raise reader.error(node, f'{what}: high - low must be a finite number (at most '
                           f'{sys.float_info.max:.4g}), not {args[1] - args[0]!r}')
    if law is model.Law.NORMAL and not math.isfinite(abs(args[0]) + 40.0 * args[1]):
        raise reader.error(node, f'{what}: mean and std so large that a draw overflows '
                           'to infinity')
    if law is model.Law.TRUNCATED_NORMAL:
        mean, std, low, high = args
        edges = ((low - mean) / std, (high - mean) / std)
        if not all(math.isfinite(e) for e in edges):
            raise reader.error(node, f'{what}: the window [low, high] lies {edges[0]:g} to '
                               f'{edges[1]:g} std from the mean; it must be a finite number '
                               'of std (a larger std)')




__all__ = ['KEYS', 'METRICS', 'MONTE_CARLO_KEYS', 'NODE_ONLY', 'RUN_LIMIT', 'SWEEPABLE',
           'TIME_LIMIT',
           'Sweep', 'SweepError', 'load_sweep']
