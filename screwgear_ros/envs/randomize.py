"""The environment's domain randomization: parameters drawn at each seeded reset.

``randomize`` maps a parameter name to

* ``(low, high)``: its value drawn uniformly from the range, independently; or
* ``{'times': OTHER, 'ratio': (low, high)}``: derived, the value of ``OTHER`` in this
  draw (drawn, or the simulation's own) times a ratio drawn uniformly from the range.
  Correlated parameters stay consistent that way: ``table_static_torque`` as
  ``table_coulomb_torque`` × a ratio >= 1 never falls below the Coulomb torque.

A draw the node refuses (two independent ranges that may cross, say) is drawn again, at
most :data:`REDRAWS` times; :meth:`Randomizer.draw` says how many draws it refused, and
the environment reports them (``info['redraws']``, and its running count ``redraws``).

Examples
--------
>>> import numpy as np
>>> from screwgear_ros import Simulation
>>> r = Randomizer(Simulation(), {'table_coulomb_torque': (2.0, 3.0),
...                               'table_static_torque': {'times': 'table_coulomb_torque',
...                                                       'ratio': (1.1, 1.4)}})
>>> drawn, simulation, redraws = r.draw(np.random.default_rng(1))
>>> drawn['table_static_torque'] > drawn['table_coulomb_torque'], redraws
(True, 0)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import ScrewgearError
from ..inprocess.simulation import Simulation
from ..params.table import ParameterError

#: The most times one reset draws again after the node refused a draw.
REDRAWS = 100


class RandomizeError(ScrewgearError, ValueError):
    """A ``randomize`` entry that cannot be drawn; the message names it and the rule."""


def _range(name: str, value: Any) -> tuple[float, float]:
    """(low, high) as two finite floats, low <= high."""
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError, OverflowError):
        raise RandomizeError(f'randomize {name}: a range (low, high) of two numbers, not '
                             f'{value!r:.60}') from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise RandomizeError(f'randomize {name}: low and high must be finite, not '
                             f'({lo!r}, {hi!r})')
    if not lo <= hi:
        raise RandomizeError(f'randomize {name}: low {lo:g} > high {hi:g}')
    return lo, hi


class Randomizer:
    """The draws of ``randomize`` (module docstring) on top of ``base``."""

    def __init__(self, base: Simulation, randomize: Mapping[str, Any] | None) -> None:
        self.base = base
        self.independent: dict[str, tuple[float, float]] = {}
        self.derived: dict[str, tuple[str, tuple[float, float]]] = {}
        values = {**base.params.as_dict(), **base.settings.as_dict()}
        for name, entry in (randomize or {}).items():
            if not isinstance(name, str) or name not in values:
                raise RandomizeError(f'randomize {name!r:.60}: not a parameter of table_sim '
                                     '(the parameter table of the README names them)')
            if isinstance(entry, Mapping):
                if set(entry) != {'times', 'ratio'}:
                    raise RandomizeError(f"randomize {name}: a derived parameter is "
                                         f"{{'times': OTHER, 'ratio': (low, high)}}, not "
                                         f'{dict(entry)!r:.80}')
                other = entry['times']
                if other not in values or other == name or other in self.derived \
                        or isinstance(randomize.get(other), Mapping):   # type: ignore[union-attr]
                    raise RandomizeError(f'randomize {name}: times {other!r:.60} must name '
                                         'another parameter of table_sim that is not '
                                         'derived itself')
                self.derived[name] = (other, _range(f'{name} ratio', entry['ratio']))
            else:
                self.independent[name] = _range(name, entry)
                for end in self.independent[name]:     # a range the node takes
                    try:
                        base.with_values(**{name: end})
                    except ParameterError as exc:
                        # a rule of several parameters (static >= Coulomb) is the draws'
                        # to meet, drawn again until they do; a value refused alone is not
                        if exc.name == name:
                            raise RandomizeError(f'randomize {name}: {exc}') from None

    @property
    def names(self) -> tuple[str, ...]:
        return (*self.independent, *self.derived)

    def draw(self, rng: np.random.Generator) -> tuple[dict[str, float], Simulation, int]:
        """The drawn values, the simulation with them, and how many draws the node refused
        first (each drawn again from ``rng``).

        Raises
        ------
        RandomizeError
            :data:`REDRAWS` draws in a row refused; the message gives the last reason.
        """
        if not self.independent and not self.derived:
            return {}, self.base, 0
        values = {**self.base.params.as_dict(), **self.base.settings.as_dict()}
        why = ''
        for redraws in range(REDRAWS + 1):
            drawn = {name: float(rng.uniform(lo, hi))
                     for name, (lo, hi) in self.independent.items()}
            for name, (other, (lo, hi)) in self.derived.items():
                drawn[name] = float(drawn.get(other, values[other])) * float(rng.uniform(lo, hi))
            try:
                return drawn, self.base.with_values(**drawn), redraws
            except ParameterError as exc:
                why = str(exc)
        raise RandomizeError(f'randomize: {REDRAWS + 1} draws in a row refused by table_sim '
                             f'(the last: {why}); narrow the ranges, or derive one parameter '
                             "from another ({'times': OTHER, 'ratio': (low, high)})")


__all__ = ['REDRAWS', 'RandomizeError', 'Randomizer']
