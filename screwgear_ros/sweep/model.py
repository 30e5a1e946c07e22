"""A sweep's data: the runs one sweep file resolves to, and what they share.

:class:`Sweep` holds the shared :class:`Bundle` (file contents, sent to the workers),
its :class:`Axis` list and one :class:`RunSpec` per run; :func:`run_seed` derives a
run's seed from the sweep seed and its index alone. No Dask, no file reading here.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from ..errors import ScrewgearError


class SweepError(ScrewgearError, ValueError):
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
        mean, std, low, high = a
        edges = ((low - mean) / std, (high - mean) / std)
        u = rng.random()
        if edges[0] < TAIL_SIGMAS and edges[1] > -TAIL_SIGMAS:
            from scipy.special import ndtr, ndtri
            lo, hi = ndtr(edges[0]), ndtr(edges[1])
            value = mean + std * float(ndtri(lo + (hi - lo) * u))
        else:
            from scipy.stats import truncnorm
            value = mean + std * float(truncnorm.ppf(u, *edges))
        return min(max(value, low), high)      # the inverse CDF's last-bit rounding


#: A truncated normal whose window lies wholly beyond this many σ from its mean is drawn
#: by SciPy's ``truncnorm`` (accurate in the far tails); nearer windows by the inverse of
#: the normal CDF over the window, whose rounding there is far below the window's width.
TAIL_SIGMAS = 5.0


@dataclass(frozen=True)
class Axis:
    """A swept parameter: its grid values or its draw; ``scale``: the values multiply
    the base value (each element of a list parameter) instead of replacing it.
    Correlated draws: ``factor`` names a shared factor (:attr:`Sweep.factors`) whose draw
    this axis takes instead of its own (so parameters scaled by one factor move
    together); ``of`` makes it derived: the run's value of parameter ``of`` times this
    axis' draw, the ratio (static = Coulomb × ratio keeps static >= Coulomb for a ratio
    >= 1). A factor itself is an axis with ``shared`` set: drawn once per run, set no
    parameter."""

    name: str
    line: int
    scale: bool = False
    values: tuple[Any, ...] = ()      # grid
    draw: Draw | None = None          # Monte Carlo
    factor: str | None = None         # takes this shared factor's draw
    of: str | None = None             # derived: (the value of ``of``) × the draw
    shared: bool = False              # a shared factor (sets no parameter)

    @property
    def column(self) -> str:
        if self.shared:
            return f'factor_{self.name}'
        if self.of is not None:
            return f'{self.name}_ratio'
        return f'{self.name}_scale' if self.scale else self.name

    def sample(self, rng: np.random.Generator) -> float:
        """One value of this axis' draw (a grid axis has none: ValueError)."""
        if self.draw is None:
            raise ValueError(f'{self.name} is a grid axis: it has no draw')
        return self.draw.sample(rng)

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
    redraws: int = 0          # draws the node refused before this one (redrawn)


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
        return digest({'scenario_name': self.scenario_name, 'scenario': self.scenario_text,
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
    factors: tuple[Axis, ...] = ()
    first_refusal: str = ''           # why the first redrawn draw was refused

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(a.column for a in (*self.grid, *self.factors, *self.draws))

    @property
    def redraws(self) -> int:
        """Draws the node refused and that were drawn again, over all runs."""
        return sum(r.redraws for r in self.runs)

    def resolved(self) -> dict[str, Any]:
        """The resolved sweep (every drawn value), as written to DIR/sweep.yaml."""
        b = self.bundle
        return {
            'sweep_file': self.path,
            'parameters_file': self.base_file,
            'scenario_file': self.scenario_file,
            'scenario_text': b.scenario_text,
            'controller_sources': {name: text for name, text in b.sources},
            'base_parameters': plain(dict(b.base)),
            'metrics': list(b.metrics),
            'time_limit': b.time_limit,
            'grid': {a.column: plain(list(a.values)) for a in self.grid},
            'monte_carlo': {'count': self.count, 'seed': self.seed,
                            **({'factors': {a.name: {a.draw.law.value: list(a.draw.arguments)}
                                            for a in self.factors if a.draw is not None}}
                               if self.factors else {}),
                            'parameters': {a.column: _law(a) for a in self.draws},
                            **({'redraws': self.redraws} if self.redraws else {})},
            'runs': [{'index': r.index, 'seed': r.seed, 'key': r.key,
                      'values': plain(dict(r.swept)),
                      **({'redraws': r.redraws} if r.redraws else {})} for r in self.runs],
        }


def _law(axis: Axis) -> dict[str, Any]:
    """An axis' draw as the resolved sweep writes it."""
    if axis.factor is not None:
        return {'factor': axis.factor}
    law = {axis.draw.law.value: list(axis.draw.arguments)} if axis.draw is not None else {}
    return {'times': axis.of, 'ratio': law} if axis.of is not None else law


def plain(value: Any) -> Any:
    """The value YAML/JSON-friendly: tuples → lists, enums → strings, NumPy → Python.

    Parameters
    ----------
    value
        Any value of a sweep (nested dicts, lists and tuples too).

    Returns
    -------
    Any
        The same value in plain Python types.

    Examples
    --------
    >>> plain({1: (Law.NORMAL, 2)})
    {'1': ['normal', 2]}
    """
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, StrEnum):
        return value.value
    return value


def digest(value: Any) -> str:
    """A short SHA-256 digest of ``value``'s canonical JSON (:func:`plain`, sorted keys).

    Parameters
    ----------
    value
        What a run depends on.

    Returns
    -------
    str
        16 hex digits; equal values give equal digests on any machine.

    Examples
    --------
    >>> digest({'a': 1, 'b': (2, 3)}) == digest({'b': [2, 3], 'a': 1})
    True
    """
    text = json.dumps(plain(value), sort_keys=True, separators=(',', ':'))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_seed(sweep_seed: int, index: int) -> int:
    """The seed of run ``index``: from the sweep seed and the index only (never from a
    worker or from the order runs finish in)."""
    return int(np.random.SeedSequence(sweep_seed, spawn_key=(index,))
               .generate_state(1, np.uint32)[0])


def drawn_column_is_number(sweep: Sweep, column: str) -> bool:
    """Whether a swept column holds numbers (a list parameter's grid values do not)."""
    return all(isinstance(dict(r.swept)[column], (int, float)) for r in sweep.runs)


__all__ = ['ARGUMENTS', 'TAIL_SIGMAS', 'Axis', 'Bundle', 'Draw', 'Law', 'RunSpec', 'Sweep', 'SweepError',
           'digest', 'drawn_column_is_number', 'plain', 'run_seed']
