"""Floquet multipliers of the homogeneous normalized equation against known answers, and
the compiled parallel kernel against the vectorized NumPy RK4 it replaced."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import brentq

from screwgear_ros.numerics import kernels as warmup
from screwgear_ros.paper import batch, floquet
from screwgear_ros.paper.normalized import NormalizedParams


def _batch_monodromy(zeta, ka, omega, kappa, phase, steps):
    """M the way floquet.monodromy found it before the compiled kernel: both fundamental
    solutions as 2N sets of batch.integrate (vectorized NumPy RK4, forcing zero)."""
    z, k, o, kp, ph = (a.reshape(-1) for a in np.broadcast_arrays(
        *(np.asarray(a, dtype=np.float64) for a in (zeta, ka, omega, kappa, phase))))
    n, zero, one = z.size, np.zeros(z.size), np.ones(z.size)
    c = batch.Coefficients(
        damping_ratio=z, stiffness_fluctuation=k, frequency_ratio=o, mean_load=zero,
        load_fluctuation_amplitude=zero, load_fluctuation_frequency=zero,
        stiffness_ratio=kp, stiffness_phase=ph, initial_displacement=zero,
        initial_velocity=zero, excitation_amplitudes=np.zeros((n, 1)),
        excitation_phases=np.zeros((n, 1)))
    dtau = 2.0 * math.pi / o / steps
    _, xs, vs = batch.integrate(batch.concatenate([c, c]), steps, np.concatenate([dtau, dtau]),
                                stride=steps, keep_from=steps, x0=np.concatenate([one, zero]),
                                v0=np.concatenate([zero, one]))
    return np.stack([np.stack([xs[-1, :n], xs[-1, n:]], axis=-1),
                     np.stack([vs[-1, :n], vs[-1, n:]], axis=-1)], axis=-2)


def test_compiled_kernel_equals_the_vectorized_numpy_rk4_bit_for_bit() -> None:
    """Same step (rk.step), same right-hand side arithmetic (normalized.rhs, forcing
    zero), same step times k·Δτ: the same matrices to the last bit, over every
    coefficient, and the same with the progress bar's chunks of the grid."""
    rng = np.random.default_rng(12)
    n = floquet._PROGRESS_CHUNK + 300              # more than one chunk with a bar
    zeta, ka = rng.uniform(0.0, 0.3, n), rng.uniform(0.0, 0.6, n)
    omega, kappa = rng.uniform(0.3, 3.0, n), rng.uniform(0.8, 1.2, n)
    phase = rng.uniform(-math.pi, math.pi, n)
    m = floquet.monodromy(zeta, ka, omega, kappa, phase, steps=150)
    assert m.shape == (n, 2, 2)
    assert np.array_equal(m, _batch_monodromy(zeta, ka, omega, kappa, phase, 150))
    assert np.array_equal(m, floquet.monodromy(zeta, ka, omega, kappa, phase, steps=150,
                                               progress='test'))
    # the paper's Ω, default steps (~2900 a period): a small ζ × k_a' grid
    zeta, ka = np.array([0.01, 0.2])[:, None], np.array([0.0, 0.25, 0.5])[None, :]
    m = floquet.monodromy(zeta, ka, 0.043, kappa=1.05, phase=0.3)
    assert m.shape == (2, 3, 2, 2)
    assert np.array_equal(m, _batch_monodromy(zeta, ka, 0.043, 1.05, 0.3,
                                              floquet.steps_per_period(0.043)).reshape(m.shape))


def _damped_transition(zeta: float, kappa: float, t: float) -> np.ndarray:
    """Transition matrix over t of x'' + 2ζx' + κx = 0 (ζ² < κ), closed form."""
    wd = math.sqrt(kappa - zeta * zeta)
    c, s, e = math.cos(wd * t), math.sin(wd * t), math.exp(-zeta * t)
    return e * np.array([[c + zeta / wd * s, s / wd], [-kappa / wd * s, c - zeta / wd * s]])


@pytest.mark.parametrize('zeta, kappa, omega', [(0.05, 1.0, 0.043), (0.2, 0.7, 0.5),
                                                 (0.0, 1.3, 2.7)])
def test_constant_stiffness_monodromy_is_the_damped_oscillators_transition(
        zeta: float, kappa: float, omega: float) -> None:
    """k_a' = 0: M is the closed-form transition matrix over T, to RK4's error, and that
    error falls 16-fold when the step halves (order 4)."""
    period = 2.0 * math.pi / omega
    exact = _damped_transition(zeta, kappa, period)
    n = floquet.steps_per_period(omega)
    errors = [np.max(np.abs(floquet.monodromy(zeta, 0.0, omega, kappa, steps=s) - exact))
              for s in (n, 2 * n)]
    assert errors[0] < 2e-6
    assert 12.0 < errors[0] / errors[1] < 20.0, errors


def test_floquet_kernel_in_the_warmup() -> None:
    assert floquet._monodromy_kernel in warmup.kernels()


CACHE_SCRIPT = r'''
import json, sys
import numpy as np
from screwgear_ros.paper import floquet
from screwgear_ros.paper.stability import PAPER_OMEGA
n = int(sys.argv[1])
m = floquet.monodromy(np.linspace(0.01, 0.2, n)[:, None], np.linspace(0.0, 0.5, n)[None, :],
                      PAPER_OMEGA, steps=200, progress=sys.argv[2] or None)
stats = getattr(floquet._monodromy_kernel, 'stats', None)     # None: not compiled
print(json.dumps({'jit': stats is not None, 'm': m.tolist(),
                  'misses': sum(stats.cache_misses.values()) if stats else 0,
                  'hits': sum(stats.cache_hits.values()) if stats else 0}))
'''


def _run(env: dict[str, str], n: int, progress: str = '') -> dict:
    proc = subprocess.run([sys.executable, '-P', '-c', CACHE_SCRIPT, str(n), progress],
                          env=env, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


@pytest.mark.ros
def test_parallel_kernel_is_cached_and_loaded_in_a_new_process(tmp_path) -> None:
    """cache=True with parallel=True: a fresh cache is filled by the first process; the
    next one, on another grid shape and with the progress bar's chunks, compiles nothing
    and gives the matrices computed in this process."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    first = _run(env, 3)
    assert first['jit'] and first['misses'] > 0
    second = _run(env, 40, 'bar')
    assert second['misses'] == 0 and second['hits'] > 0, second
    n = 40
    here = floquet.monodromy(np.linspace(0.01, 0.2, n)[:, None],
                             np.linspace(0.0, 0.5, n)[None, :], 0.043, steps=200)
    assert np.array_equal(np.array(second['m']), here)


@pytest.mark.ros
def test_no_jit_runs_the_same_source_with_the_same_matrices() -> None:
    """NUMBA_DISABLE_JIT=1: prange is range, the same source in plain Python."""
    plain = _run(dict(os.environ, NUMBA_DISABLE_JIT='1'), 3)
    assert not plain['jit']
    n = 3
    compiled = floquet.monodromy(np.linspace(0.01, 0.2, n)[:, None],
                                 np.linspace(0.0, 0.5, n)[None, :], 0.043, steps=200)
    assert np.array_equal(np.array(plain['m']), compiled)


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
