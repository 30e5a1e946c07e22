"""Sweep files: many runs of one scenario over a grid and/or a Monte Carlo draw.

:func:`load_sweep` reads a sweep file, reads the files it names (on the client: their
contents, not their paths, go to the workers) and resolves every run: its index, its seed
(derived from the sweep seed and the index alone), its parameter values and the digest
of everything it depends on. Every run is validated before any starts, by the node's
own rules (:func:`~screwgear_ros.params.table.split_parameters`: ranges, the cross-parameter
rules, the RK4 stability limit); an error is a :class:`SweepError` naming the file,
the line and the entry. No Dask here: this module runs anywhere the package does.

Why one module of this length: it is the one reader of the sweep format, and each of its
checks must name the file's line (and, for a refused run, the run), so the format's rules
stay together.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..params.declarations import ParameterError, declared
from ..params.sets import split_parameters
from ..params.table import SimSettings, TableParams
from ..params.yaml_reader import YamlReader
from ..sim.metrics import Metrics
from ..sim.scenario import ScenarioError, load_scenario
from ..sim.simulation import ParameterFileError, file_values

#: The top-level keys of a sweep file.
KEYS = ('parameters', 'scenario', 'metrics', 'time_limit', 'grid', 'monte_carlo')
MONTE_CARLO_KEYS = ('count', 'seed', 'parameters')
#: The metrics a sweep can keep: the flat names of a run's metrics.
METRICS = tuple(Metrics(0.0, None, (), (), (0.0, 0.0), None, 0).as_dict())
#: Node settings that mean nothing for an in-process run (the node's pacing, clock, DDS
#: lockstep and recorder): sweeping them would change no result.
NODE_ONLY = ('record', 'real_time_factor', 'publish_clock', 'lockstep')
#: Default wall-time limit of one run, s.
TIME_LIMIT = 300.0
#: Parameters that may be swept (read-only ones too: a run sets them at its start).
SWEEPABLE = tuple(p.name for cls in (TableParams, SimSettings) for p in declared(cls)
                  if p.name not in NODE_ONLY)
READ_ONLY = frozenset(p.name for cls in (TableParams, SimSettings) for p in declared(cls)
                      if p.declaration.read_only)


class SweepError(ValueError):
    """A sweep that cannot run; the message names the file, the line and the entry."""


class Law(StrEnum):
    """A Monte Carlo distribution: its arguments in the file, in order."""

    UNIFORM = 'uniform'                      # [low, high]
    NORMAL = 'normal'                        # [mean, std]
    TRUNCATED_NORMAL = 'truncated_normal'    # [mean, std, low, high]


ARGUMENTS = {Law.UNIFORM: ('low', 'high'), Law.NORMAL: ('mean', 'std'),
             Law.TRUNCATED_NORMAL: ('mean', 'std', 'low', 'high')}


@dataclass(frozen=True)
class Draw:
    """One Monte Carlo draw: ``law`` with its ``arguments``."""

    law: Law
    arguments: tuple[float, ...]

    def sample(self, rng: np.random.Generator) -> float:
        a = self.arguments
        if self.law is Law.UNIFORM:
            return float(rng.uniform(a[0], a[1]))
        if self.law is Law.NORMAL:
            return float(rng.normal(a[0], a[1]))
        from scipy.special import ndtr, ndtri
        mean, std, low, high = a
        lo, hi = ndtr((low - mean) / std), ndtr((high - mean) / std)
        value = mean + std * float(ndtri(lo + (hi - lo) * rng.random()))
        return min(max(value, low), high)      # the inverse CDF's last-bit rounding


@dataclass(frozen=True)
class Axis:
    """A swept parameter: its grid values or its draw; ``scale``: the values multiply
    the base value (each element of a list parameter) instead of replacing it."""

    name: str
    line: int
    scale: bool = False
    values: tuple[Any, ...] = ()      # grid
    draw: Draw | None = None          # Monte Carlo

    @property
    def column(self) -> str:
        return f'{self.name}_scale' if self.scale else self.name

    def apply(self, base: Any, value: Any) -> Any:
        if not self.scale:
            return value
        if isinstance(base, (list, tuple)):
            return [float(x) * value for x in base]
        return base * value


@dataclass(frozen=True)
class RunSpec:
    """One run: ``index`` in the sweep, its ``seed``, the swept values by column
    (:attr:`Axis.column`), the parameters they set, and ``key``: the digest of all the
    run depends on."""

    index: int
    seed: int
    swept: tuple[tuple[str, Any], ...]
    overrides: tuple[tuple[str, Any], ...]
    key: str


@dataclass(frozen=True)
class Bundle:
    """What every run of a sweep shares, as contents (picklable, sent to the workers):
    the scenario file's text and the controller modules beside it, the base values."""

    scenario_name: str
    scenario_text: str
    sources: tuple[tuple[str, str], ...]      # (file name, text) of controller modules
    base: tuple[tuple[str, Any], ...]         # base file, then the scenario's parameters
    metrics: tuple[str, ...]
    time_limit: float

    @property
    def digest(self) -> str:
        return _digest({'scenario_name': self.scenario_name, 'scenario': self.scenario_text,
                        'sources': self.sources, 'base': self.base,
                        'metrics': self.metrics, 'time_limit': self.time_limit})


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: the shared :class:`Bundle`, its axes, its runs, and the
    resolved document written to ``DIR/sweep.yaml``."""

    path: str
    bundle: Bundle
    grid: tuple[Axis, ...]
    draws: tuple[Axis, ...]
    count: int
    seed: int
    runs: tuple[RunSpec, ...]
    base_file: str | None
    scenario_file: str

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(a.column for a in (*self.grid, *self.draws))

    def resolved(self) -> dict[str, Any]:
        """The resolved sweep (every drawn value), as written to DIR/sweep.yaml."""
        b = self.bundle
        return {
            'sweep_file': self.path,
            'parameters_file': self.base_file,
            'scenario_file': self.scenario_file,
            'scenario_text': b.scenario_text,
            'controller_sources': {name: text for name, text in b.sources},
            'base_parameters': _plain(dict(b.base)),
            'metrics': list(b.metrics),
            'time_limit': b.time_limit,
            'grid': {a.column: _plain(list(a.values)) for a in self.grid},
            'monte_carlo': {'count': self.count, 'seed': self.seed,
                            'parameters': {a.column: {a.draw.law.value: list(a.draw.arguments)}
                                           for a in self.draws}},
            'runs': [{'index': r.index, 'seed': r.seed, 'key': r.key,
                      'values': _plain(dict(r.swept))} for r in self.runs],
        }


def _plain(value: Any) -> Any:
    """YAML/JSON-friendly: tuples → lists, enums → strings, NumPy → Python."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, StrEnum):
        return value.value
    return value


def _digest(value: Any) -> str:
    text = json.dumps(_plain(value), sort_keys=True, separators=(',', ':'))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_seed(sweep_seed: int, index: int) -> int:
    """The seed of run ``index``: from the sweep seed and the index only (never from a
    worker or from the order runs finish in)."""
    return int(np.random.SeedSequence(sweep_seed, spawn_key=(index,))
               .generate_state(1, np.uint32)[0])


def load_sweep(path: str | Path) -> Sweep:
    """Read, resolve and validate a sweep file; :class:`SweepError` says what is wrong."""
    path = Path(path)
    reader = YamlReader.open(path, SweepError)
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
        node = top['parameters'][1]
        name = reader.value(node)
        if not isinstance(name, str) or not name:
            raise reader.error(node, 'parameters names a parameter file (path relative to '
                               'the sweep file)')
        base_file = str((here / name).resolve())
        try:
            base = file_values(base_file)
        except ParameterFileError as exc:
            raise reader.error(node, str(exc)) from None
        for key in NODE_ONLY:
            base.pop(key, None)              # the node's settings: no meaning in-process
    node = top['scenario'][1]
    name = reader.value(node)
    if not isinstance(name, str) or not name:
        raise reader.error(node, 'scenario names a scenario file (path relative to the '
                           'sweep file)')
    scenario_file = here / name
    try:
        scenario = load_scenario(scenario_file)
        scenario_text = scenario_file.read_text(encoding='utf-8')
    except (ScenarioError, OSError) as exc:
        raise reader.error(node, f'scenario: {exc}') from None
    explicit = (yaml.safe_load(scenario_text) or {}).get('parameters') or {}
    values = dict(scenario.values)
    base = {**base, **{k: values[k] for k in explicit}}
    sources = _controller_sources(scenario, scenario_file.resolve().parent)

    metrics = _metrics(reader, top['metrics'][1])
    time_limit = TIME_LIMIT
    if 'time_limit' in top:
        time_limit = reader.number(top['time_limit'][1], 'time_limit (s of wall time per '
                                   'run)', low=0.0, strict=True)
    grid = _grid(reader, top['grid'][1]) if 'grid' in top else ()
    count, seed, draws = 1, 0, ()
    if 'monte_carlo' in top:
        count, seed, draws = _monte_carlo(reader, top['monte_carlo'][1])
    names = [a.name for a in (*grid, *draws)]
    for axis in (*grid, *draws):
        if names.count(axis.name) > 1:
            raise reader.error(axis.line or None,
                               f'{axis.name} is swept twice (grid and monte_carlo)')

    bundle = Bundle(scenario_file.name, scenario_text, sources,
                    tuple(_plain(base).items()), metrics, time_limit)
    runs = _runs(reader, bundle, scenario, grid, draws, count, seed)
    return Sweep(str(path), bundle, grid, draws, count, seed, tuple(runs), base_file,
                 str(scenario_file.resolve()))


def _controller_sources(scenario: Any, directory: Path) -> tuple[tuple[str, str], ...]:
    """The controller's module file when it sits beside the scenario (shipped to the
    workers); an installed module is the workers' to have."""
    spec = scenario.controller
    if spec is None or spec.use == 'demo':
        return ()
    module = spec.use.partition(':')[0]
    candidate = directory / (module.replace('.', '/') + '.py')
    if '.' not in module and candidate.is_file():
        return ((candidate.name, candidate.read_text(encoding='utf-8')),)
    return ()


def _metrics(reader: YamlReader, node: yaml.Node) -> tuple[str, ...]:
    value = reader.value(node)
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not value:
        raise reader.error(node, f'metrics is a list of metric names (known: '
                           f'{", ".join(METRICS)})')
    for item, name in zip(node.value if isinstance(node, yaml.SequenceNode) else [node],
                          value):
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
                           'table of the README names them)')


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


def _grid(reader: YamlReader, node: yaml.Node) -> tuple[Axis, ...]:
    axes = []
    for name, (key, value) in reader.mapping(node, 'grid').items():
        _parameter_name(reader, key, name)
        scale, values_node = _scaled(reader, value, f'grid {name}')
        values = reader.value(values_node)
        if not isinstance(values_node, yaml.SequenceNode) or not values:
            raise reader.error(values_node, f'grid {name}: a non-empty list of values')
        if scale:
            for item in values_node.value:
                reader.number(item, f'grid {name}: a scale factor')
        axes.append(Axis(name, key.start_mark.line + 1, scale, tuple(values)))
    if not axes:
        raise reader.error(node, 'grid: name at least one parameter with its values')
    return tuple(axes)


def _monte_carlo(reader: YamlReader, node: yaml.Node) -> tuple[int, int, tuple[Axis, ...]]:
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
        known = tuple(law.value for law in Law)
        if len(laws) != 1 or next(iter(laws)) not in known:
            raise reader.error(law_node, f'monte_carlo {name}: one distribution of '
                               f'{", ".join(known)}, e.g. {{uniform: [low, high]}}')
        (law_name, (_, args_node)), = laws.items()
        law = Law(law_name)
        expected = ARGUMENTS[law]
        if not isinstance(args_node, yaml.SequenceNode) or len(args_node.value) != len(expected):
            raise reader.error(args_node, f'monte_carlo {name}: {law.value} takes '
                               f'[{", ".join(expected)}]')
        args = tuple(reader.number(n, f'monte_carlo {name}: {arg}')
                     for n, arg in zip(args_node.value, expected))
        if law is not Law.UNIFORM and args[1] <= 0.0:
            raise reader.error(args_node, f'monte_carlo {name}: std must be > 0')
        low_high = args[-2:] if law is not Law.NORMAL else None
        if low_high is not None and not low_high[0] < low_high[1]:
            raise reader.error(args_node, f'monte_carlo {name}: low must be below high')
        axes.append(Axis(name, key.start_mark.line + 1, scale, draw=Draw(law, args)))
    if not axes:
        raise reader.error(entries['parameters'][1], 'monte_carlo parameters: name at least '
                           'one parameter with its distribution')
    return count, seed, tuple(axes)


def _runs(reader: YamlReader, bundle: Bundle, scenario: Any, grid: tuple[Axis, ...],
          draws: tuple[Axis, ...], count: int, seed: int) -> list[RunSpec]:
    """Every run, in index order (grid point major, then draw), each validated."""
    base = dict(bundle.base)
    points = list(itertools.product(*(a.values for a in grid))) if grid else [()]
    shared = bundle.digest
    runs = []
    for index in range(len(points) * count):
        point = points[index // count]
        rng_seed = run_seed(seed, index)
        rng = np.random.default_rng(rng_seed)
        chosen = [*zip(grid, point), *((a, a.draw.sample(rng)) for a in draws)]
        overrides = {a.name: a.apply(base.get(a.name, _default(a.name)), v)
                     for a, v in chosen}
        _validate(reader, scenario, base, overrides, chosen, index)
        swept = tuple((a.column, _plain(v)) for a, v in chosen)
        key = _digest({'bundle': shared, 'index': index, 'seed': rng_seed,
                       'overrides': overrides})
        runs.append(RunSpec(index, rng_seed, swept, tuple(_plain(overrides).items()), key))
    return runs


def _default(name: str) -> Any:
    from ..params.sets import default_values
    return default_values()[name]


def _validate(reader: YamlReader, scenario: Any, base: dict[str, Any],
              overrides: dict[str, Any], chosen: list[tuple[Axis, Any]], index: int) -> None:
    """The run as the node would take it: its parameters, then the scenario's parameter
    changes on top of them (each a run of the node's validation)."""
    def where(name: str | None) -> int | None:
        for axis, _ in chosen:
            if axis.name == name:
                return axis.line
        for axis, _ in chosen:            # a rule of several parameters (RK4's dt limit):
            try:                          # the first swept value that breaks it alone
                split_parameters({**base, axis.name: overrides[axis.name]})
            except ParameterError:
                return axis.line
        return chosen[0][0].line if chosen else None

    swept = ', '.join(f'{a.column} = {v!r}' for a, v in chosen)
    try:
        params, settings = split_parameters({**base, **overrides})
        values = {**params.as_dict(), **settings.as_dict()}
        for action in scenario.actions:
            if action.kind != 'parameters':
                continue
            for name in action.value:
                if name in READ_ONLY and values.get(name) != action.value[name]:
                    raise ParameterError(name, action.value[name], f'is read-only: the '
                                         f'scenario changes it at {action.time:g} s '
                                         f'(line {action.line}), which the node refuses')
            values = {**values, **action.value}
            split_parameters(values)
    except ParameterError as exc:
        hint = ''
        if isinstance(exc.value, str):
            try:
                float(exc.value)
                hint = (f' (YAML reads {exc.value} as text: a number with an exponent '
                        f'needs a dot and a signed exponent, e.g. 1.0e+7, 2.0e-5)')
            except ValueError:
                pass
        raise reader.error(where(exc.name), f'run {index} ({swept}) is refused by '
                           f'table_sim: {exc}{hint}') from None


def drawn_column_is_number(sweep: Sweep, column: str) -> bool:
    """Whether a swept column holds numbers (a list parameter's grid values do not)."""
    return all(isinstance(dict(r.swept)[column], (int, float)) for r in sweep.runs)


__all__ = [
    'KEYS',
    'METRICS',
    'NODE_ONLY',
    'SWEEPABLE',
    'TIME_LIMIT',
    'Axis',
    'Bundle',
    'Draw',
    'Law',
    'RunSpec',
    'Sweep',
    'SweepError',
    'drawn_column_is_number',
    'load_sweep',
    'run_seed',
]
