"""The RK4 step of screwgear_ros.numerics.rk: its tableau checked against the order conditions
(test/rk_tableaus.py), the step and its stability polynomial those of that tableau, the
step's measured order beside two other tableaus', one step on three kinds of state, and
the Hermite interpolant's order.

Independent references: the closed form of the damped oscillator y'' + 2ζy' + y = 0
and RK4's stability polynomial 1 + z + z²/2 + z³/6 + z⁴/24 (Taylor's series of e^z to
fourth order).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from numba import njit
from rk_tableaus import EULER, MIDPOINT, RK4, Tableau, tableau_step

from screwgear_ros.numerics import rk

ZETA = 0.1
WD = math.sqrt(1.0 - ZETA ** 2)


def _oscillator(t, y, args):
    """y = (x, x') of x'' + 2ζx' + x = 0 (tuple or array)."""
    return (y[1], -2.0 * ZETA * y[1] - y[0]) if isinstance(y, tuple) else np.array(
        [y[1], -2.0 * ZETA * y[1] - y[0]])


@njit
def _oscillator_compiled(t, y, args):
    """The same in compiled code (tuples)."""
    return (y[1], -2.0 * ZETA * y[1] - y[0])


def _exact(t):
    """x(0) = 1, x'(0) = 0."""
    e = np.exp(-ZETA * t)
    x = e * (np.cos(WD * t) + ZETA / WD * np.sin(WD * t))
    v = -e * np.sin(WD * t) / WD
    return np.array([x, v])


def test_rk4_tableau_has_order_four_and_its_stability_polynomial():
    residuals = RK4.order_conditions()
    assert len(residuals) == 8 and all(r == 0 for r in residuals.values())
    assert RK4.stability_coefficients() == (1, 1, Fraction(1, 2), Fraction(1, 6),
                                            Fraction(1, 24))
    assert tuple(float(g) for g in RK4.stability_coefficients()) == rk.STABILITY
    z = np.array([-2.0 + 0.5j, 2.8j, -2.785])
    expected = 1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24
    assert np.allclose(rk.amplification(z), expected, rtol=1e-15)
    assert RK4.weights() == ((1, 2, 2, 1), 6)
    # the midpoint rule is second order and not third
    assert next(int(k[0]) for k, r in MIDPOINT.order_conditions().items() if r != 0) == 3


def test_tableaus_that_break_their_claims_are_refused():
    with pytest.raises(ValueError, match='order conditions'):
        Tableau('RK4 with a typo', 4, c=(0, '1/2', '1/2', 1),
                   a=((), ('1/2',), (0, '1/2'), (0, 0, 1)), b=('1/6', '1/3', '1/6', '1/3'))
    with pytest.raises(ValueError, match='sum of row'):
        Tableau('bad node', 2, c=(0, 1), a=((), ('1/2',)), b=(0, 1))
    with pytest.raises(ValueError, match='slope of stage 1 alone'):          # Kutta's 3/8 rule
        Tableau('3/8 rule', 4, c=(0, '1/3', '2/3', 1),
                   a=((), ('1/3',), ('-1/3', 1), (1, -1, 1)), b=('1/8', '3/8', '3/8', '1/8'))


@pytest.mark.parametrize('tableau', [RK4, MIDPOINT, EULER], ids=lambda t: t.name)
def test_the_step_has_the_order_of_its_tableau(tableau):
    """Global error at t = 10 of y'' + 2ζy' + y = 0 against the closed form, halving h."""
    errors = []
    for n in (400, 800, 1600):
        h = 10.0 / n
        y = np.array([1.0, 0.0])
        for k in range(n):
            y = tableau_step(tableau, _oscillator, k * h, y, h, None)
        errors.append(np.max(np.abs(y - _exact(10.0))))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    print(f'{tableau.name}: errors {errors}, measured order {orders}')
    assert np.all(np.abs(orders - tableau.order) < 0.1)


def test_the_step_is_its_tableaus_bit_for_bit():
    """rk.step, written out, against the RK4 tableau interpreted, on arrays and tuples."""
    h = 0.01
    y_array, y_tuple = np.array([1.0, 0.0]), (1.0, 0.0)
    for k in range(1000):
        expected = tableau_step(RK4, _oscillator, k * h, y_array, h, None)
        y_array = rk.step(_oscillator, k * h, y_array, h, None)
        assert np.array_equal(y_array, expected)
        expected = tableau_step(RK4, _oscillator, k * h, y_tuple, h, None)
        y_tuple = rk.step(_oscillator, k * h, y_tuple, h, None)
        assert y_tuple == expected


def test_one_step_on_arrays_tuples_and_in_compiled_code_gives_the_same_bits():
    @njit
    def compiled(n, h):
        y = (1.0, 0.0)
        for k in range(n):
            y = rk.step(_oscillator_compiled, k * h, y, h, None)
        return y

    h, n = 0.01, 1000
    y_array, y_tuple = np.array([1.0, 0.0]), (1.0, 0.0)
    for k in range(n):
        y_array = rk.step(_oscillator, k * h, y_array, h, None)
        y_tuple = rk.step(_oscillator, k * h, y_tuple, h, None)
    assert tuple(y_array) == y_tuple == compiled(n, h)
    assert np.max(np.abs(y_array - _exact(n * h))) < 1e-9


def test_step_from_reuses_the_first_slope():
    y, h = (0.3, -0.2), 0.05
    assert rk.step_from(_oscillator, 1.0, y, h, _oscillator(1.0, y, None), None) == rk.step(
        _oscillator, 1.0, y, h, None)


def test_hermite_interpolant_of_an_rk4_step_is_fourth_order():
    """Largest error over θ ∈ [0, 1] of the interpolant of one RK4 step from the exact
    state, against the closed form: O(h⁴) (cubic Hermite; the ends are O(h⁵))."""
    t0 = 0.7
    errors = []
    for h in (0.2, 0.1, 0.05):
        y0 = _exact(t0)
        f0 = _oscillator(t0, y0, None)
        y1 = rk.step(_oscillator, t0, y0, h, None)
        f1 = _oscillator(t0 + h, y1, None)
        thetas = np.linspace(0.0, 1.0, 41)
        interpolated = np.array([rk.hermite(y0, f0, y1, f1, h, th) for th in thetas])
        exact = np.array([_exact(t0 + th * h) for th in thetas])
        errors.append(np.max(np.abs(interpolated - exact)))
        assert np.array_equal(interpolated[0], y0) and np.allclose(interpolated[-1], y1,
                                                                    rtol=0, atol=1e-16)
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    print('Hermite interpolant errors', errors, 'order', orders)
    assert np.all(orders > 3.8)
