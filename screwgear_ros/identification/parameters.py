"""The parameters to fit: names checked against the declarations, bounds, and the scaled
coordinates the optimizer moves in.

A positive parameter is fitted in log coordinates (x = ln value: a step means the same
relative change whatever its unit, and the value cannot cross zero); one whose range
includes zero or negative values linearly, scaled by the width of its bounds. Default
bounds: a tenth to ten times the base value, within the declared range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from .adapter import declarations, settings_names
from .errors import FitParameterError

#: Default bounds of a positive parameter: base / SPAN … base · SPAN.
SPAN = 10.0


class Scale(Enum):
    LOG = 'log'
    LINEAR = 'linear'


@dataclass(frozen=True)
class FitParameter:
    """One parameter to fit: its base value, bounds and scale."""

    name: str
    base: float
    low: float
    high: float
    scale: Scale
    unit: str = ''

    def to_x(self, value: float) -> float:
        if self.scale is Scale.LOG:
            return math.log(value)
        return (value - self.low) / (self.high - self.low)

    def to_value(self, x: float) -> float:
        if self.scale is Scale.LOG:
            return math.exp(x)
        return self.low + x * (self.high - self.low)

    @property
    def x_bounds(self) -> tuple[float, float]:
        return self.to_x(self.low), self.to_x(self.high)


def parse_bounds(items: Sequence[str]) -> dict[str, tuple[float, float]]:
    """``NAME=LO:HI`` strings → {name: (lo, hi)}."""
    bounds = {}
    for item in items:
        name, sep, text = item.partition('=')
        lo, colon, hi = text.partition(':')
        try:
            if not (sep and colon):
                raise ValueError
            pair = float(lo), float(hi)
        except ValueError:
            raise FitParameterError(f'--bounds {item!r}: not NAME=LO:HI') from None
        if not (all(math.isfinite(v) for v in pair) and pair[0] < pair[1]):
            raise FitParameterError(f'--bounds {item!r}: LO < HI, both finite')
        if name.strip() in bounds:
            raise FitParameterError(f'--bounds names {name.strip()} twice: give each '
                                    'parameter one NAME=LO:HI')
        bounds[name.strip()] = pair
    return bounds


def _pair(name: object, pair: object) -> tuple[float, float]:
    """A (low, high) bound of the API's ``bounds``, checked as ``--bounds`` is."""
    try:
        lo, hi = (float(v) for v in pair)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise FitParameterError(f'bounds[{name!r}] = {pair!r}: not a (LO, HI) pair of '
                                'numbers') from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise FitParameterError(f'bounds[{name!r}] = {pair!r}: LO < HI, both finite')
    return lo, hi


def _declared_range(name: str, declaration: Any) -> tuple[float, float, bool]:
    low = -math.inf if declaration.low is None else float(declaration.low)
    high = math.inf if declaration.high is None else float(declaration.high)
    return low, high, bool(declaration.strict)


def fit_parameters(names: Sequence[str], base: Mapping[str, Any],
                   bounds: Mapping[str, tuple[float, float]] | None = None
                   ) -> tuple[FitParameter, ...]:
    """The parameters ``names`` with their base values (``base`` over the defaults).

    Raises
    ------
    FitParameterError
        An unknown name, a setting or read-only parameter, one that is not a real
        number, a repeated name, bounds for a parameter not fitted, or bounds outside
        the declared range.
    """
    known = declarations()
    bounds = {str(name): _pair(name, pair) for name, pair in dict(bounds or {}).items()}
    stray = sorted(set(bounds) - set(names))
    if stray:
        raise FitParameterError(f'--bounds {stray[0]}: not among the parameters to fit '
                                f'({", ".join(names)})')
    if not names:
        raise FitParameterError('--fit names no parameter')
    if not all(isinstance(n, str) for n in names):
        raise FitParameterError(f'--fit: parameter names are text, not {names!r}')
    if len(set(names)) != len(names):
        raise FitParameterError(f'--fit names a parameter twice: {", ".join(names)}')
    fitted = []
    for name in names:
        if name in settings_names():
            raise FitParameterError(f'{name} is a setting of the simulation, not a '
                                    'parameter of the table\'s model')
        if name not in known:
            raise FitParameterError(f'{name} is not a parameter of table_sim')
        kind, declaration, default = known[name]
        if declaration.read_only:
            raise FitParameterError(f'{name} is read-only (fixed for a run): it cannot '
                                    'be fitted')
        if kind.name != 'FLOAT':
            raise FitParameterError(f'{name} is a {kind.value}, not a real number: only '
                                    'real-valued parameters can be fitted')
        value = float(base.get(name, default))
        low, high, strict = _declared_range(name, declaration)
        if name in bounds:
            lo, hi = bounds[name]
            if lo < low or hi > high or (strict and lo <= low):
                raise FitParameterError(
                    f'--bounds {name}={lo:g}:{hi:g} is outside its declared range '
                    f'{declaration.range_text()}')
        elif value > 0.0 and low >= 0.0:
            lo = max(value / SPAN, low * (1 + 1e-9) if strict else low)
            hi = min(value * SPAN, high)
        else:
            # a tenth to ten times a base of 0 (or of a parameter that may be negative)
            # is no range: the user names one
            raise FitParameterError(f'{name} is {value:g} in the base file, so the default '
                                    'bounds (a tenth to ten times the base value) are no '
                                    f'range: give one with --bounds {name}=LO:HI')
        scale = Scale.LOG if lo > 0.0 else Scale.LINEAR
        fitted.append(FitParameter(name, value, lo, hi, scale, declaration.unit))
    return tuple(fitted)


def start_point(fitted: Sequence[FitParameter]) -> np.ndarray:
    """The base values in scaled coordinates, moved inside the bounds."""
    x = []
    for p in fitted:
        value = min(max(p.base, p.low), p.high)
        if p.scale is Scale.LOG and value <= 0.0:
            value = math.sqrt(p.low * p.high)
        x.append(p.to_x(value))
    return np.array(x)


def starts(fitted: Sequence[FitParameter], count: int, seed: int) -> list[np.ndarray]:
    """``count`` starting points: the base values, then seeded draws around them (a
    third of each bound's width either way), the same for the same seed."""
    x0 = start_point(fitted)
    lo, hi = (np.array(b) for b in zip(*(p.x_bounds for p in fitted), strict=True))
    rng = np.random.default_rng(seed)
    points = [x0]
    for _ in range(max(0, count - 1)):
        width = (hi - lo) / 3.0
        points.append(np.clip(x0 + rng.uniform(-1.0, 1.0, len(x0)) * width,
                              lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo)))
    return points


def values_of(fitted: Sequence[FitParameter], x: np.ndarray) -> dict[str, float]:
    return {p.name: p.to_value(float(v)) for p, v in zip(fitted, x, strict=True)}


__all__ = ['SPAN', 'FitParameter', 'Scale', 'fit_parameters', 'parse_bounds', 'start_point',
           'starts', 'values_of']
