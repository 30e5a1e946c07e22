"""Floquet multipliers of the homogeneous normalized equation against known answers."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from screwgear_ros import batch, floquet
from screwgear_ros.normalized import NormalizedParams


def test_constant_stiffness_multipliers_are_the_damped_decay() -> None:
    zeta = np.array([0.0, 0.01, 0.05, 0.2])[:, None]
    omega = np.array([0.043, 0.5, 2.7])[None, :]
    m = floquet.monodromy(zeta, 0.0, omega)
    expected = np.exp(-2.0 * math.pi * zeta / omega)
    np.testing.assert_allclose(floquet.spectral_radius(m), expected, rtol=5e-5)
    np.testing.assert_allclose(floquet.growth_rate(m, omega), -zeta + 0 * omega, atol=1e-6)


def test_liouville_determinant_with_fluctuating_stiffness() -> None:
    zeta, ka, omega = np.meshgrid([0.02, 0.1], [0.1, 0.45], [0.043, 1.1, 2.0], indexing='ij')
    m = floquet.monodromy(zeta, ka, omega, kappa=1.05, phase=0.3)
    np.testing.assert_allclose(np.linalg.det(m), np.exp(-4.0 * math.pi * zeta / omega),
                               rtol=5e-5)


def _mathieu_edges(h: float) -> tuple[float, float]:
    """Ω at the edges of the principal tongue of x'' + (1 + h·cos Ωτ)x = 0.

    With s = 2t = Ωτ: x_tt + (a − 2q·cos 2t)x = 0, a = 4/Ω², |q| = 2h/Ω²; the edges are
    a = 1 ± |q| − q²/8 ∓ |q|³/64 (McLachlan's series for b1 and a1).
    """
    def edge(sign: float):
        def f(omega: float) -> float:
            a, q = 4.0 / omega ** 2, 2.0 * h / omega ** 2
            return a - (1.0 + sign * q - q * q / 8.0 - sign * q ** 3 / 64.0)
        return brentq(f, 1.0, 3.0)
    return tuple(sorted((edge(1.0), edge(-1.0))))


def test_undamped_principal_tongue_edges_match_mathieu() -> None:
    h = 0.2
    low, high = _mathieu_edges(h)
    inside = np.array([low + 0.004, 0.5 * (low + high), high - 0.004])
    outside = np.array([low - 0.004, high + 0.004])
    assert np.all(floquet.spectral_radius(floquet.monodromy(0.0, h, inside)) > 1.005)
    np.testing.assert_allclose(floquet.spectral_radius(floquet.monodromy(0.0, h, outside)),
                               1.0, atol=1e-6)


def test_damped_threshold_at_twice_the_natural_frequency() -> None:
    # First-order theory (Landau & Lifshitz §27): unstable at Ω = 2 when k_a' > 4ζ.
    zeta = 0.05
    r = floquet.spectral_radius(floquet.monodromy(zeta, np.array([0.17, 0.23]), 2.0))
    assert r[0] < 1.0 < r[1]
    # Growth rate at the tongue centre ≈ k_a'/4 − ζ.
    g = floquet.growth_rate(floquet.monodromy(zeta, 0.4, 2.0), 2.0)
    assert abs(g - (0.4 / 4.0 - zeta)) < 0.1 * 0.4 / 4.0


def test_periodic_state_is_the_long_run_steady_state() -> None:
    params = [NormalizedParams(damping_ratio=z, stiffness_fluctuation=k)
              for z, k in ((0.02, 0.1), (0.1, 0.4))]
    c = batch.Coefficients.stack(params)
    x0, v0 = floquet.periodic_state(c)
    period = 2.0 * math.pi / 0.043
    n = 4000
    # Brute force: 12 periods from the paper's initial state (transient < e^{-0.02·1750}).
    _, x, v = batch.integrate(c, 12 * n, period / n, stride=n)
    np.testing.assert_allclose(x[-1], x0, rtol=1e-9)
    np.testing.assert_allclose(v[-1], v0, rtol=1e-7, atol=1e-9)
