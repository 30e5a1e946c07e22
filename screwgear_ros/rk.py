"""Explicit Runge–Kutta methods as data, one step function, and the step's interpolant.

A method is its Butcher tableau (:class:`Tableau`: nodes c, coupling a, weights b, in
exact fractions, checked against the order conditions it claims). :data:`RK4` is the
classical fourth-order method every integrator of the package uses: the node's hot loop
(:mod:`screwgear_ros.integrator`, six scalars), the normalized equation
(:mod:`screwgear_ros.normalized`, two scalars) and the batch sweeps
(:mod:`screwgear_ros.batch`, NumPy arrays). They all call :func:`step`, the one
definition of a step:

    k_0 = f(t, y),   k_s = f(t + c_s·h, y + a_s·h·k_{s−1}),   y_new = y + h·Σ b_s·k_s

The step supports the tableaus whose stage s takes the slope of stage s − 1 alone (RK4,
the midpoint rule, Heun's method, ...), so it keeps no stage array. The weights are
applied as RK4 is written by hand, y + (h/D)·(w_0·k_0 + w_1·(k_1 + k_2) + w_3·k_3) with
integer w = D·b: consecutive stages of equal weight are summed first (fewer
multiplications, and the arithmetic of RK4 as written by hand, so that its results stay
bit for bit those of the formula).

States are anything with the vector operations of :func:`axpy`, :func:`add` and
:func:`scale`: floats and NumPy arrays in Python, tuples of floats in Python and in
compiled code. Called from a numba-compiled function with a compiled right-hand side
``fun(t, y, args)`` (returning the slope as a tuple), the step is unrolled over the
tableau's stages at compile time, with its coefficients as constants and ``fun`` called
directly: the compiled loop is as fast as a hand-written RK4 and allocates nothing.

:func:`hermite` is the step's cubic Hermite interpolant (dense output from both ends and
their slopes, error O(h⁴)); the integrator locates contact changes inside a step with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from typing import Any, Callable, Sequence

from numba import njit, types
from numba.cpython.unsafe.tuple import tuple_setitem
from numba.extending import overload

Number = int | float | Fraction | str


def _fractions(values: Sequence[Number]) -> tuple[Fraction, ...]:
    return tuple(Fraction(v) for v in values)


@dataclass(frozen=True)
class Tableau:
    """An explicit Runge–Kutta method: nodes ``c``, coupling ``a`` (row s holds a_s0 ..
    a_s,s−1), weights ``b``, and the ``order`` it must have (checked exactly, up to 4).

    :func:`step` needs each stage to use the previous stage's slope only
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
        return [sum((a * x for a, x in zip(row, v)), Fraction(0)) for row in self.a]

    def order_conditions(self) -> dict[str, Fraction]:
        """Residuals of the conditions for orders 1–4 (one per rooted tree), keyed
        '<order>: <condition>'; a method of order p has zero residuals up to p."""
        b, c = self.b, self.c

        def dot(v: Sequence[Fraction]) -> Fraction:
            return sum((x * y for x, y in zip(b, v)), Fraction(0))

        ac = self._times_a(c)
        return {
            '1: Σb = 1': dot([Fraction(1)] * len(b)) - 1,
            '2: Σbc = 1/2': dot(c) - Fraction(1, 2),
            '3: Σbc² = 1/3': dot([x * x for x in c]) - Fraction(1, 3),
            '3: Σb·Ac = 1/6': dot(ac) - Fraction(1, 6),
            '4: Σbc³ = 1/4': dot([x ** 3 for x in c]) - Fraction(1, 4),
            '4: Σbc·Ac = 1/8': dot([x * y for x, y in zip(c, ac)]) - Fraction(1, 8),
            '4: Σb·Ac² = 1/12': dot(self._times_a([x * x for x in c])) - Fraction(1, 12),
            '4: Σb·AAc = 1/24': dot(self._times_a(ac)) - Fraction(1, 24),
        }

    def stability_coefficients(self) -> tuple[Fraction, ...]:
        """Coefficients of the stability polynomial R(z) = Σ_k γ_k·z^k (the step of
        y' = λy is y·R(λh)): γ_0 = 1, γ_k = bᵀ·A^(k−1)·1."""
        v = [Fraction(1)] * self.stages
        gammas = [Fraction(1)]
        for _ in range(self.stages):
            gammas.append(sum((x * y for x, y in zip(self.b, v)), Fraction(0)))
            v = self._times_a(v)
        return tuple(gammas)

    def amplification(self, z: complex) -> complex:
        """R(z), the factor one step multiplies y' = λy by, at z = λ·h."""
        result: complex = 0.0
        for gamma in reversed(_float_stability(self)):
            result = result * z + gamma
        return result

    def weights(self) -> tuple[tuple[int, ...], int]:
        """(w, D): integer weights and their common denominator, b = w/D."""
        denominator = math.lcm(*(x.denominator for x in self.b))
        return tuple(int(x * denominator) for x in self.b), denominator


@lru_cache(maxsize=None)
def _float_stability(tableau: Tableau) -> tuple[float, ...]:
    """The stability polynomial's coefficients as floats, once per tableau: the exact
    fractions are slow to recompute for every R(z) of a bisection on dt."""
    return tuple(float(gamma) for gamma in tableau.stability_coefficients())


#: The classical fourth-order Runge–Kutta method.
RK4 = Tableau('classical RK4', 4, c=(0, '1/2', '1/2', 1),
              a=((), ('1/2',), (0, '1/2'), (0, 0, 1)),
              b=('1/6', '1/3', '1/3', '1/6'))


# ------------------------------------------------------------------ vector operations
# Python bodies serve floats, NumPy arrays and (with NUMBA_DISABLE_JIT=1) tuples; the
# overloads give compiled code the same operations on tuples of floats, unrolled.

def axpy(y: Any, a: float, x: Any) -> Any:
    """y + a·x, componentwise."""
    if isinstance(y, tuple):
        return tuple(yi + a * xi for yi, xi in zip(y, x))
    return y + a * x


def add(x: Any, y: Any) -> Any:
    """x + y, componentwise."""
    if isinstance(x, tuple):
        return tuple(xi + yi for xi, yi in zip(x, y))
    return x + y


def scale(a: float, x: Any) -> Any:
    """a·x, componentwise."""
    if isinstance(x, tuple):
        return tuple(a * xi for xi in x)
    return a * x


@overload(axpy)
def _axpy_compiled(y, a, x):
    if isinstance(y, types.BaseTuple):
        def impl(y, a, x):
            out = y
            for i in range(len(y)):
                out = tuple_setitem(out, i, y[i] + a * x[i])
            return out
        return impl
    if isinstance(y, types.Number):
        return lambda y, a, x: y + a * x
    return None


@overload(add)
def _add_compiled(x, y):
    if isinstance(x, types.BaseTuple):
        def impl(x, y):
            out = x
            for i in range(len(x)):
                out = tuple_setitem(out, i, x[i] + y[i])
            return out
        return impl
    if isinstance(x, types.Number):
        return lambda x, y: x + y
    return None


@overload(scale)
def _scale_compiled(a, x):
    if isinstance(x, types.BaseTuple):
        def impl(a, x):
            out = x
            for i in range(len(x)):
                out = tuple_setitem(out, i, a * x[i])
            return out
        return impl
    if isinstance(x, types.Number):
        return lambda a, x: a * x
    return None


# ------------------------------------------------------------------ the step

def _identity(function: Callable) -> Callable:
    return function


def _stages(fun: Callable, tableau: Tableau, wrap: Callable) -> Callable:
    """The step as a chain of per-stage functions, stage coefficients bound as constants:
    ``run(t, y, h, k, args)`` takes the slope k_0 = f(t, y) and returns y_new.

    ``wrap`` is applied to each function: identity for Python, ``njit(inline='always')``
    for compiled callers (the chain then compiles to straight-line code)."""
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
            return wrap(finish)
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
        return wrap(stage)

    first = link(1)

    def run(t, y, h, k, args):
        return first(t, y, h, args, k, k, k, False)
    return wrap(run)


@lru_cache(maxsize=None)
def _python_step(fun: Callable, tableau: Tableau) -> Callable:
    return _stages(fun, tableau, _identity)


def step_from(fun: Callable, t: float, y: Any, h: float, slope: Any, args: Any) -> Any:
    """One RK4 step of y' = fun(t, y, args) from (t, y) over h, given ``slope`` =
    fun(t, y, args) (a caller that has it saves the first evaluation)."""
    return _python_step(fun, RK4)(t, y, h, slope, args)


def step(fun: Callable, t: float, y: Any, h: float, args: Any) -> Any:
    """One RK4 step of y' = fun(t, y, args) from (t, y) over h: the new state."""
    return _python_step(fun, RK4)(t, y, h, fun(t, y, args), args)


_COMPILE = njit(inline='always')


@lru_cache(maxsize=None)
def _compiled_step(dispatcher: Any) -> Callable:
    return _stages(dispatcher, RK4, _COMPILE)


@overload(step_from, inline='always')
def _step_from_compiled(fun, t, y, h, slope, args):
    run = _compiled_step(fun.dispatcher)

    def impl(fun, t, y, h, slope, args):
        return run(t, y, h, slope, args)
    return impl


@overload(step, inline='always')
def _step_compiled(fun, t, y, h, args):
    run = _compiled_step(fun.dispatcher)
    f = fun.dispatcher

    def impl(fun, t, y, h, args):
        return run(t, y, h, f(t, y, args), args)
    return impl


# ------------------------------------------------------------------ dense output

def hermite(y0: Any, f0: Any, y1: Any, f1: Any, h: float, theta: float) -> Any:
    """The cubic Hermite interpolant of a step from (y0, slope f0) to (y1, slope f1)
    over h, at t0 + θ·h (0 ≤ θ ≤ 1):

        y(θ) = y0 + θ·(h·f0 + θ·(3Δ − h·(2f0 + f1) + θ·(h·(f0 + f1) − 2Δ))),  Δ = y1 − y0.

    With the ends of an RK4 step its error is O(h⁴) over the step."""
    delta = axpy(y1, -1.0, y0)
    both = add(f0, f1)
    cubic = axpy(scale(-2.0, delta), h, both)
    quadratic = axpy(scale(3.0, delta), -h, add(f0, both))
    inner = axpy(quadratic, theta, cubic)
    return axpy(y0, theta, axpy(scale(h, f0), theta, inner))


@overload(hermite, inline='always')
def _hermite_compiled(y0: Any, f0: Any, y1: Any, f1: Any, h: float, theta: float):
    # The body above uses only the vector operations, which compile for tuples and floats
    # (numba wants the implementation's parameters, annotations included, to be these).
    return hermite if isinstance(y0, (types.BaseTuple, types.Number)) else None


__all__ = ['Tableau', 'RK4', 'axpy', 'add', 'scale', 'step', 'step_from',
           'hermite']
