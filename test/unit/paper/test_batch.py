"""The vectorized batch RK4 against the scalar compiled integrator and a closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.paper import batch
from screwgear_ros.paper.normalized import NormalizedParams, response

CASES = [
    NormalizedParams(),  # the paper's normalized case
    NormalizedParams(damping_ratio=0.12, stiffness_fluctuation=0.35, frequency_ratio=0.7,
                     mean_load=3.0, excitation_amplitudes=(2.0, 0.5, 0.25),
                     excitation_phases=(0.3, -1.0, 2.0), load_fluctuation_amplitude=1.5,
                     load_fluctuation_frequency=0.93, stiffness_ratio=1.07,
                     stiffness_phase=0.4, initial_displacement=-1.0, initial_velocity=2.0),
    NormalizedParams(damping_ratio=0.0, stiffness_fluctuation=0.2, frequency_ratio=2.0,
                     excitation_amplitudes=(1.0,), excitation_phases=(0.0,)),
]


def test_batch_matches_scalar_integrator_for_every_set() -> None:
    """NumPy over N sets and the compiled scalar loop take the same step (rk.step) on
    right-hand sides with the same arithmetic: the same numbers, bit for bit."""
    c = batch.Coefficients.stack(CASES)
    tau, x, v = batch.response(c, 200.0, dtau=0.02, stride=5)
    for i, p in enumerate(CASES):
        tau_s, states = response(p, 200.0, dtau=0.02, stride=5)
        np.testing.assert_allclose(tau, tau_s, rtol=0, atol=1e-12 * tau_s[-1])
        assert np.array_equal(x[:, i], states[:, 0])
        assert np.array_equal(v[:, i], states[:, 1])


def test_one_step_size_per_set() -> None:
    c = batch.Coefficients.stack(CASES[:2])
    steps = np.array([0.01, 0.03])
    tau, x, _ = batch.integrate(c, 3000, steps, stride=100)
    assert tau.shape == (31, 2)
    for i, p in enumerate(CASES[:2]):
        _, states = response(p, 3000 * steps[i], dtau=steps[i], stride=100)
        assert np.array_equal(x[:, i], states[:, 0])


def test_constant_coefficients_against_damped_oscillator_closed_form() -> None:
    zeta, kappa, f0, x0, v0 = 0.07, 1.3, 4.0, 0.5, -0.2
    c = batch.Coefficients.stack([NormalizedParams(
        damping_ratio=zeta, stiffness_fluctuation=0.0, stiffness_ratio=kappa, mean_load=f0,
        excitation_amplitudes=(0.0,), excitation_phases=(0.0,),
        initial_displacement=x0, initial_velocity=v0)])
    tau, x, _ = batch.response(c, 50.0, dtau=0.005, stride=20)
    sigma, wd = zeta, math.sqrt(kappa - zeta ** 2)  # x'' + 2ζx' + κx: roots −ζ ± i·ω_d
    a = x0 - f0 / kappa
    exact = f0 / kappa + np.exp(-sigma * tau) * (
        a * np.cos(wd * tau) + (v0 + sigma * a) / wd * np.sin(wd * tau))
    assert np.max(np.abs(x[:, 0] - exact)) < 1e-9


def test_grid_order_sampling_and_round_trip() -> None:
    z = np.array([0.01, 0.1, 0.2])
    k = np.array([0.0, 0.3])
    c, shape = batch.Coefficients.grid(CASES[0], damping_ratio=z, stiffness_fluctuation=k)
    assert shape == (3, 2) and len(c) == 6
    assert np.array_equal(c.damping_ratio.reshape(shape), np.meshgrid(z, k, indexing='ij')[0])
    assert np.array_equal(c.stiffness_fluctuation.reshape(shape)[1], k)
    p = c.params(3)
    assert p.damping_ratio == 0.1 and p.stiffness_fluctuation == 0.3
    assert p.excitation_amplitudes == CASES[0].excitation_amplitudes
    tau, x, _ = batch.integrate(c, 1000, 0.01, stride=50, keep_from=600)
    np.testing.assert_allclose(tau, np.arange(600, 1001, 50) * 0.01, rtol=1e-14)
    assert x.shape == (len(tau), 6)
    with pytest.raises(ValueError):
        batch.Coefficients.grid(CASES[0], excitation_amplitudes=np.ones(3))
