"""The classical fourth-order Runge–Kutta method (RK4): its step, its stability
polynomial and the step's interpolant, the one definition every fixed-step integrator of
the package uses: the node's hot loop (:mod:`screwgear_ros.numerics.integrator`, six scalars),
the normalized equation (:mod:`screwgear_ros.paper.normalized`, two scalars) and the batch
sweeps (:mod:`screwgear_ros.paper.batch`, NumPy arrays). The method is its Butcher tableau

    c = (0, ½, ½, 1),   a_s,s−1 = (½, ½, 1),   b = (1, 2, 2, 1)/6,

written out in :func:`step_from` as RK4 is written by hand,
y + (h/6)·((k_0 + 2·(k_1 + k_2)) + k_3): each stage takes the previous stage's slope
alone, so the step keeps no stage array. The tests check the tableau against the order
conditions and the stability polynomial against it (test/rk_tableaus.py).

States are anything with the vector operations of :func:`axpy`, :func:`add` and
:func:`scale`: floats and NumPy arrays in Python, tuples of floats in Python and in
compiled code. Called from a numba-compiled function with a compiled right-hand side
``fun(t, y, args)`` (returning the slope as a tuple), the step compiles to straight-line
code with ``fun`` called directly: as fast as a hand-written RK4 in the caller, and it
allocates nothing.

:func:`hermite` is the step's cubic Hermite interpolant (dense output from both ends and
their slopes, error O(h⁴)); the integrator locates contact changes inside a step with it.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np
from numba import njit, types
from numba.cpython.unsafe.tuple import tuple_setitem
from numba.extending import overload

#: RK4's stability polynomial R(z) = Σ_k γ_k·z^k (a step of y' = λy multiplies y by
#: R(λh)): with as many stages as its order (4), Taylor's series of e^z to that order.
STABILITY = (1.0, 1.0, 1.0 / 2.0, 1.0 / 6.0, 1.0 / 24.0)


def amplification(z: complex | np.ndarray) -> complex | np.ndarray:
    """R(z), the factor one RK4 step multiplies y' = λy by, at z = λ·h (Horner); on an
    array of z, elementwise."""
    result: complex | np.ndarray = 0.0
    for gamma in reversed(STABILITY):
        result = result * z + gamma
    return result


# ------------------------------------------------------------------ vector operations
# Python bodies serve floats, NumPy arrays and (with NUMBA_DISABLE_JIT=1) tuples; the
# overloads give compiled code the same operations on tuples of floats, unrolled. An
# overload is called with numba types and its implementation with values under the same
# parameter names, and numba wants both signatures, annotations included, to be equal:
# so both take Any.

def axpy(y: Any, a: float, x: Any) -> Any:
    """y + a·x, componentwise."""
    if isinstance(y, tuple):
        return tuple(yi + a * xi for yi, xi in zip(y, x, strict=True))
    return y + a * x


def add(x: Any, y: Any) -> Any:
    """x + y, componentwise."""
    if isinstance(x, tuple):
        return tuple(xi + yi for xi, yi in zip(x, y, strict=True))
    return x + y


def scale(a: float, x: Any) -> Any:
    """a·x, componentwise."""
    if isinstance(x, tuple):
        return tuple(a * xi for xi in x)
    return a * x


@overload(axpy)
def _axpy_compiled(y: Any, a: Any, x: Any) -> Callable | None:
    if isinstance(y, types.BaseTuple):
        def impl(y: Any, a: Any, x: Any) -> Any:
            out = y
            for i in range(len(y)):
                # an intrinsic, called in compiled code only (numba supplies its context)
                out = tuple_setitem(out, i, y[i] + a * x[i])  # type: ignore[call-arg]
            return out
        return impl
    if isinstance(y, types.Number):
        def scalar(y: Any, a: Any, x: Any) -> Any:
            return y + a * x
        return scalar
    return None


@overload(add)
def _add_compiled(x: Any, y: Any) -> Callable | None:
    if isinstance(x, types.BaseTuple):
        def impl(x: Any, y: Any) -> Any:
            out = x
            for i in range(len(x)):
                # an intrinsic, called in compiled code only (numba supplies its context)
                out = tuple_setitem(out, i, x[i] + y[i])  # type: ignore[call-arg]
            return out
        return impl
    if isinstance(x, types.Number):
        def scalar(x: Any, y: Any) -> Any:
            return x + y
        return scalar
    return None


@overload(scale)
def _scale_compiled(a: Any, x: Any) -> Callable | None:
    if isinstance(x, types.BaseTuple):
        def impl(a: Any, x: Any) -> Any:
            out = x
            for i in range(len(x)):
                # an intrinsic, called in compiled code only (numba supplies its context)
                out = tuple_setitem(out, i, a * x[i])  # type: ignore[call-arg]
            return out
        return impl
    if isinstance(x, types.Number):
        def scalar(a: Any, x: Any) -> Any:
            return a * x
        return scalar
    return None


# ------------------------------------------------------------------ the step

def _identity(function: Callable) -> Callable:
    return function


def _rk4(fun: Callable, wrap: Callable) -> Callable:
    """The step of y' = fun(t, y, args) as ``run(t, y, h, k_0, args)``, given the slope
    k_0 = fun(t, y, args): the new state. ``wrap`` is the identity for Python and
    ``njit(inline='always')`` for compiled callers (``fun`` is then a compiled function,
    called directly)."""

    def run(t: float, y: Any, h: float, k0: Any, args: Any) -> Any:
        half = 0.5 * h
        k1 = fun(t + half, axpy(y, half, k0), args)
        k2 = fun(t + half, axpy(y, half, k1), args)
        k3 = fun(t + h, axpy(y, h, k2), args)
        return axpy(y, h / 6.0, add(add(k0, scale(2.0, add(k1, k2))), k3))
    return wrap(run)


@cache
def _python_step(fun: Callable) -> Callable:
    return _rk4(fun, _identity)


def step_from(fun: Callable, t: float, y: Any, h: float, slope: Any, args: Any) -> Any:
    """One RK4 step of y' = fun(t, y, args) from (t, y) over h, given ``slope`` =
    fun(t, y, args) (a caller that has it saves the first evaluation)."""
    return _python_step(fun)(t, y, h, slope, args)


def step(fun: Callable, t: float, y: Any, h: float, args: Any) -> Any:
    """One RK4 step of y' = fun(t, y, args) from (t, y) over h: the new state."""
    return _python_step(fun)(t, y, h, fun(t, y, args), args)


_COMPILE = njit(inline='always')


@cache
def _compiled_step(dispatcher: Any) -> Callable:
    return _rk4(dispatcher, _COMPILE)


@overload(step_from, inline='always')
def _step_from_compiled(fun: Any, t: Any, y: Any, h: Any, slope: Any, args: Any) -> Callable:
    run = _compiled_step(fun.dispatcher)

    def impl(fun: Any, t: Any, y: Any, h: Any, slope: Any, args: Any) -> Any:
        return run(t, y, h, slope, args)
    return impl


@overload(step, inline='always')
def _step_compiled(fun: Any, t: Any, y: Any, h: Any, args: Any) -> Callable:
    run = _compiled_step(fun.dispatcher)
    f = fun.dispatcher

    def impl(fun: Any, t: Any, y: Any, h: Any, args: Any) -> Any:
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
def _hermite_compiled(y0: Any, f0: Any, y1: Any, f1: Any, h: float, theta: float
                      ) -> Callable | None:
    # The body above uses only the vector operations, which compile for tuples and floats
    # (numba wants the implementation's parameters, annotations included, to be these).
    return hermite if isinstance(y0, (types.BaseTuple, types.Number)) else None


__all__ = [
    'STABILITY',
    'add',
    'amplification',
    'axpy',
    'hermite',
    'scale',
    'step',
    'step_from',
]
