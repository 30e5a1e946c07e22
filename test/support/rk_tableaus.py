"""Explicit Runge–Kutta methods as data, for the tests of :mod:`screwgear_ros.numerics.rk`.

A method is its Butcher tableau (:class:`Tableau`: nodes c, coupling a, weights b, in
exact fractions, checked against the order conditions it claims). :data:`RK4` is the
tableau the package's step writes out; :func:`tableau_step` interprets any tableau whose
stage s takes the slope of stage s − 1 alone (RK4, the midpoint rule, Euler, ...), with
the weights applied as RK4 is written by hand (consecutive stages of equal weight summed
first), so that on RK4 it is the package's step bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from functools import cache
from typing import Any

from screwgear_ros.numerics.rk import add, axpy, scale

Number = int | float | Fraction | str


def _fractions(values: Sequence[Number]) -> tuple[Fraction, ...]:
    return tuple(Fraction(v) for v in values)


@dataclass(frozen=True)
class Tableau:
    """An explicit Runge–Kutta method: nodes ``c``, coupling ``a`` (row s holds a_s0 ..
    a_s,s−1), weights ``b``, and the ``order`` it must have (checked exactly, up to 4).

    :func:`tableau_step` needs each stage to use the previous stage's slope only
    (a_sj = 0 for j < s − 1), which is also checked.
    """

    name: str
    order: int
    c: tuple[Fraction, ...]
    a: tuple[tuple[Fraction, ...], ...]
    b: tuple[Fraction, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, 'c', _fractions(self.c))
        object.__setattr__(self, 'a', tuple(_fractions(row) for row in self.a))
        object.__setattr__(self, 'b', _fractions(self.b))
        s = len(self.b)
        if s < 1 or len(self.c) != s or len(self.a) != s:
            raise ValueError(f'{self.name}: c, a and b need one entry per stage')
        for i, row in enumerate(self.a):
            if len(row) != i:
                raise ValueError(f'{self.name}: row {i} of a needs {i} entries (explicit method)')
            if sum(row, Fraction(0)) != self.c[i]:
                raise ValueError(f'{self.name}: c_{i} must be the sum of row {i} of a')
            if any(row[:-1]):
                raise ValueError(f'{self.name}: stage {i} must take the slope of stage {i - 1} '
                                 'alone (the step function keeps no stage array)')
        if not 1 <= self.order <= 4:
            raise ValueError(f'{self.name}: order conditions are checked up to order 4')
        failed = [cond for cond, residual in self.order_conditions().items()
                  if int(cond[0]) <= self.order and residual != 0]
        if failed:
            raise ValueError(f'{self.name}: violates the order conditions {failed}')

    @property
    def stages(self) -> int:
        return len(self.b)

    def _times_a(self, v: Sequence[Fraction]) -> list[Fraction]:
        return [sum((a * x for a, x in zip(row, v, strict=False)), Fraction(0)) for row in self.a]

    def order_conditions(self) -> dict[str, Fraction]:
        """Residuals of the conditions for orders 1–4 (one per rooted tree), keyed
        '<order>: <condition>'; a method of order p has zero residuals up to p."""
        b, c = self.b, self.c

        def dot(v: Sequence[Fraction]) -> Fraction:
            return sum((x * y for x, y in zip(b, v, strict=False)), Fraction(0))

        ac = self._times_a(c)
        return {
            '1: Σb = 1': dot([Fraction(1)] * len(b)) - 1,
            '2: Σbc = 1/2': dot(c) - Fraction(1, 2),
            '3: Σbc² = 1/3': dot([x * x for x in c]) - Fraction(1, 3),
            '3: Σb·Ac = 1/6': dot(ac) - Fraction(1, 6),
            '4: Σbc³ = 1/4': dot([x ** 3 for x in c]) - Fraction(1, 4),
            '4: Σbc·Ac = 1/8': dot([x * y for x, y in zip(c, ac, strict=False)]) - Fraction(1, 8),
            '4: Σb·Ac² = 1/12': dot(self._times_a([x * x for x in c])) - Fraction(1, 12),
            '4: Σb·AAc = 1/24': dot(self._times_a(ac)) - Fraction(1, 24),
        }

    def stability_coefficients(self) -> tuple[Fraction, ...]:
        """Coefficients of the stability polynomial R(z) = Σ_k γ_k·z^k (the step of
        y' = λy is y·R(λh)): γ_0 = 1, γ_k = bᵀ·A^(k−1)·1."""
        v = [Fraction(1)] * self.stages
        gammas = [Fraction(1)]
        for _ in range(self.stages):
            gammas.append(sum((x * y for x, y in zip(self.b, v, strict=False)), Fraction(0)))
            v = self._times_a(v)
        return tuple(gammas)

    def weights(self) -> tuple[tuple[int, ...], int]:
        """(w, D): integer weights and their common denominator, b = w/D."""
        denominator = math.lcm(*(x.denominator for x in self.b))
        return tuple(int(x * denominator) for x in self.b), denominator


#: The classical fourth-order Runge–Kutta method (:mod:`screwgear_ros.numerics.rk`).
RK4 = Tableau('classical RK4', 4, c=(0, '1/2', '1/2', 1),
              a=((), ('1/2',), (0, '1/2'), (0, 0, 1)),
              b=('1/6', '1/3', '1/3', '1/6'))
MIDPOINT = Tableau('midpoint rule', 2, c=(0, '1/2'), a=((), ('1/2',)), b=(0, 1))
EULER = Tableau('explicit Euler', 1, c=(0,), a=((),), b=(1,))


@cache
def _stages(fun: Callable, tableau: Tableau) -> Callable:
    """The step as a chain of per-stage functions, stage coefficients bound as constants:
    ``run(t, y, h, k, args)`` takes the slope k_0 = f(t, y) and returns y_new."""
    weights, denominator = tableau.weights()
    last = tableau.stages - 1

    def link(s: int) -> Callable:
        """Stages s.. : given k_{s−1}, the weighted sum ``acc`` of the closed groups of
        equal weight and the open group's sum ``part``, return y_new."""
        w_prev = float(weights[s - 1])
        if s > last:
            def finish(t, y, h, args, k, acc, part, started):
                term = part if w_prev == 1.0 else scale(w_prev, part)
                return axpy(y, h / denominator, add(acc, term) if started else term)
            return finish
        rest = link(s + 1)
        closes = weights[s] != weights[s - 1]      # stage s − 1 ends a group of equal weight
        c, a = float(tableau.c[s]), float(tableau.a[s][s - 1])

        def stage(t, y, h, args, k, acc, part, started):
            k_new = fun(t + c * h, axpy(y, a * h, k), args)
            if closes:
                term = part if w_prev == 1.0 else scale(w_prev, part)
                return rest(t, y, h, args, k_new, add(acc, term) if started else term, k_new,
                            True)
            return rest(t, y, h, args, k_new, acc, add(part, k_new), started)
        return stage

    first = link(1)

    def run(t, y, h, k, args):
        return first(t, y, h, args, k, k, k, False)
    return run


def tableau_step(tableau: Tableau, fun: Callable, t: float, y: Any, h: float,
                 args: Any) -> Any:
    """One step of ``tableau`` for y' = fun(t, y, args) from (t, y) over h."""
    return _stages(fun, tableau)(t, y, h, fun(t, y, args), args)
