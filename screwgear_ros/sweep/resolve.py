"""A sweep's runs: each resolved from its grid point and draw, and validated as the node
would take it (:func:`~screwgear_ros.sim.parameter_set.split_parameters`, then the scenario's
parameter changes on top), before any run starts.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from typing import Any

import numpy as np

from ..params.declarations import ParameterError, declared
from ..params.table import SimSettings, TableParams
from ..params.yaml_reader import YamlReader
from ..sim.parameter_set import default_values, split_parameters
from .model import Axis, Bundle, RunSpec, SweepError, digest, plain, run_seed

#: Parameters the node refuses to change while it runs.
READ_ONLY = frozenset(p.name for cls in (TableParams, SimSettings) for p in declared(cls)
                      if p.declaration.read_only)


def resolve_runs(reader: YamlReader, bundle: Bundle, scenario: Any, grid: tuple[Axis, ...],
                 draws: tuple[Axis, ...], count: int, seed: int,
                 validated: Collection[str] = frozenset(), factors: tuple[Axis, ...] = (),
                 redraw: int = 0) -> tuple[list[RunSpec], str]:
    """Every run, in index order (grid point major, then draw), each validated but those
    whose key is in ``validated`` (a key digests everything a run depends on, so a run
    finished before under it was validated then, by the same rules); and why the first
    redrawn draw was refused ('' if none was).

    A draw the node refuses is drawn again from the run's own generator, at most
    ``redraw`` times (then the sweep is refused with the last reason); the run counts its
    redraws (:attr:`RunSpec.redraws`). The shared factors are drawn first, then each
    drawn parameter in file order, then the derived ones take their ratio's draw."""
    base = dict(bundle.base)
    start = {**default_values(), **base}      # what each swept value applies to
    shared = bundle.digest
    runs = []
    first_refusal = ''
    for index in range(run_count(grid, count)):
        point = grid_point(grid, index // count)
        rng_seed = run_seed(seed, index)
        rng = np.random.default_rng(rng_seed)
        for attempt in range(redraw + 1):
            chosen = [*zip(grid, point, strict=True), *_draw(reader, index, rng, factors,
                                                               draws)]
            overrides = _overrides(reader, index, start, chosen)
            key = digest({'bundle': shared, 'index': index, 'seed': rng_seed,
                          'overrides': overrides})
            if key in validated:
                break
            try:
                _validate(reader, scenario, base, overrides,
                          [(a, v) for a, v in chosen if not a.shared], index)
                break
            except SweepError as exc:
                if not draws or attempt == redraw:
                    if attempt:
                        raise SweepError(f'{exc} (after {attempt} redraws of its draw; '
                                         'monte_carlo redraw sets the most)') from None
                    raise
                first_refusal = first_refusal or str(exc)
        swept = tuple((a.column, plain(v)) for a, v in chosen)
        runs.append(RunSpec(index, rng_seed, swept, tuple(plain(overrides).items()), key,
                            attempt))
    return runs, first_refusal


def _draw(reader: YamlReader, index: int, rng: np.random.Generator,
          factors: tuple[Axis, ...], draws: tuple[Axis, ...]) -> list[tuple[Axis, float]]:
    """One draw of a run: the shared factors, then each drawn axis (a factor's user takes
    the factor's value)."""
    values = {f.name: f.sample(rng) for f in factors}
    chosen = [(f, values[f.name]) for f in factors]
    chosen += [(a, values[a.factor] if a.factor is not None else a.sample(rng)) for a in draws]
    for axis, value in chosen:
        if not math.isfinite(value):
            raise reader.error(axis.line, f'run {index}: {axis.column} drew {value!r}')
    return chosen


def _overrides(reader: YamlReader, index: int, start: dict[str, Any],
               chosen: list[tuple[Axis, Any]]) -> dict[str, Any]:
    """The parameters a run's values set: each axis' value (scaled or not), then each
    derived parameter: the value of the parameter it names in this run × its ratio."""
    overrides = {a.name: a.apply(start[a.name], v)
                 for a, v in chosen if not a.shared and a.of is None}
    for axis, ratio in chosen:
        if axis.of is None:
            continue
        other = overrides.get(axis.of, start[axis.of])
        if isinstance(other, bool) or not isinstance(other, (int, float)):
            raise reader.error(axis.line, f'run {index}: {axis.name} is {axis.of} × a ratio, '
                               f'but {axis.of} is {other!r}, not a number')
        overrides[axis.name] = float(other) * ratio
    return overrides


def run_count(grid: tuple[Axis, ...], count: int) -> int:
    """The runs of a grid (every combination of its axes' values) with ``count`` draws
    at each point, counted without building the grid."""
    return math.prod(len(a.values) for a in grid) * count


def grid_point(grid: tuple[Axis, ...], number: int) -> tuple[Any, ...]:
    """The values of grid point ``number`` in :func:`itertools.product` order (the last
    axis varies fastest), without building the grid."""
    point = []
    for axis in reversed(grid):
        number, k = divmod(number, len(axis.values))
        point.append(axis.values[k])
    return tuple(reversed(point))


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


__all__ = ['READ_ONLY', 'grid_point', 'resolve_runs', 'run_count']
