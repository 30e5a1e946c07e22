"""The normalized 1-DOF equation (model.md §5): its own closed form, and the exact
reduction of the 3-DOF model to it.

With b = 0, one path (conventional mode), `time` phase and T_load = T1·r2/r1 the 3-DOF
equations reduce exactly to m_e·δ̈ + c·δ̇ + K(t)·δ = F_m + m_e·r1·T_v·sin(ω_v t)/I1 − m_e·ε̈,
so both integrations must agree to integration accuracy: their difference must shrink
like dt⁴ when the step is halved, not level off.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.numerics.integrator import trajectory
from screwgear_ros.paper import normalized as nz
from screwgear_ros.params.table import ParameterError, TableParams
from screwgear_ros.physics.packed import Drive, pack
from screwgear_ros.physics.quantities import natural_frequency

LENGTH = 1e-6   # l, m: the paper's length scale


def _three_dof_in_x(p: TableParams, torque: float, x0: float, v0: float, dt: float,
                    t_end: float, stride: int) -> np.ndarray:
    """x = δ/l of the 3-DOF model at t = (j + 1)·stride·dt, started at δ = l·x0, δ̇ = l·ω0·v0."""
    m = pack(p)
    r1, r2, w0, we = p.radius_pinion_1, p.radius_table, natural_frequency(p), p.mesh_frequency
    amp, ph = np.array(p.ste_amplitudes), np.array(p.ste_phases)
    n = np.arange(1, len(amp) + 1)
    eps0 = float(np.sum(amp * np.sin(ph)))
    deps0 = float(np.sum(amp * n * we * np.cos(ph)))
    y = np.array([(LENGTH * x0 + eps0) / r1, 0.0, 0.0, (LENGTH * w0 * v0 + deps0) / r1, 0.0, 0.0])
    count = round(t_end / (stride * dt))
    out = np.empty((count, 6))
    trajectory(y, 0, dt, stride, out, m, Drive(torque, 1.0, torque * r2 / r1))
    t = (np.arange(count) + 1) * stride * dt
    eps = np.sum(amp[:, None] * np.sin(n[:, None] * we * t + ph[:, None]), axis=0)
    return (r1 * out[:, 0] - r2 * out[:, 1] - eps) / LENGTH


def _one_dof(p: TableParams, torque: float, x0: float, v0: float, dt: float, t_end: float,
             stride: int) -> np.ndarray:
    q = nz.from_table(p, torque, LENGTH, x0, v0)
    w0 = natural_frequency(p)
    _, states = nz.response(q, w0 * t_end, dtau=w0 * dt, stride=stride)
    return states[1:, 0]


REDUCTION_CASES = {
    'paper': {},
    # two STE harmonics (the n² factor), phases, torque fluctuation on pinion 1,
    # thermal derating and preload stiffness (κ ≠ 1), stiffness phase
    'rich': {'ste_amplitudes': (1.5384e-3, 3e-4), 'ste_phases': (0.3, -1.0),
                 'torque_fluctuation_amplitude': 100.0, 'torque_fluctuation_frequency': 500.0,
                 'preload_stiffness': 1e6, 'thermal_coefficient': 1e-3, 'temperature_rise': 20.0,
                 'mesh_stiffness_phase': 0.5},
}


@pytest.mark.parametrize('case', REDUCTION_CASES)
def test_three_dof_reduces_exactly_to_the_normalized_equation(case):
    p = TableParams(mode='conventional', backlash=0.0, mesh_phase='time',
                    **REDUCTION_CASES[case])
    torque, x0, v0, t_end = 400.0, 0.5, 0.5, 0.2
    diffs = {}
    for dt, stride in ((20e-6, 50), (10e-6, 100)):
        x3 = _three_dof_in_x(p, torque, x0, v0, dt, t_end, stride)
        x1 = _one_dof(p, torque, x0, v0, dt, t_end, stride)
        assert len(x3) == len(x1) == 200
        diffs[dt] = np.max(np.abs(x3 - x1))
    scale = np.max(np.abs(x1))
    print(f'{case}: max |x_3dof − x_1dof| = {diffs[20e-6]:.2e} (20 µs), '
          f'{diffs[10e-6]:.2e} (10 µs) on max |x| = {scale:.1f}')
    assert scale > 500.0                                   # a real response, not a trivial one
    assert diffs[10e-6] < 1e-8 * scale                     # measured ~1.3e-12 relative
    assert 12.0 < diffs[20e-6] / diffs[10e-6] < 20.0       # shrinks like dt⁴ (16×)


def test_normalized_closed_form():
    """k_a' = 0, no STE, no fluctuation: x'' + 2ζx' + κx = f0, a damped oscillator about f0/κ."""
    zeta, kappa, f0, x0, v0 = 0.05, 1.3, 512.8, 0.5, 0.5
    q = nz.NormalizedParams(damping_ratio=zeta, stiffness_fluctuation=0.0, stiffness_ratio=kappa,
                            mean_load=f0, excitation_amplitudes=(), excitation_phases=(),
                            initial_displacement=x0, initial_velocity=v0)
    tau, states = nz.response(q, 200.0, dtau=0.005, stride=20)
    wn = math.sqrt(kappa)
    z = zeta / wn                      # damping ratio of this oscillator
    wd = wn * math.sqrt(1 - z * z)
    xs = f0 / kappa
    a = x0 - xs
    b = (v0 + z * wn * a) / wd
    exact = xs + np.exp(-z * wn * tau) * (a * np.cos(wd * tau) + b * np.sin(wd * tau))
    assert tau[0] == 0.0 and states[0, 0] == x0 and states[0, 1] == v0
    assert np.max(np.abs(states[:, 0] - exact)) / xs < 1e-9


def test_from_table_gives_the_papers_normalized_case():
    """Default TableParams at 400 N·m, l = 1 µm → ζ = 0.05, k_a' = 0.1, f0 = 512.8, fa = 1538.4."""
    q = nz.from_table(TableParams(), 400.0, 1e-6, 0.5, 0.5)
    ref = nz.NormalizedParams()
    assert q.damping_ratio == pytest.approx(ref.damping_ratio, rel=1e-12)
    assert q.stiffness_fluctuation == pytest.approx(ref.stiffness_fluctuation, rel=1e-12)
    assert q.mean_load == pytest.approx(ref.mean_load, abs=0.05)
    assert q.excitation_amplitudes == pytest.approx(ref.excitation_amplitudes, rel=1e-12)
    # Ω: 0.043277 with m_e = 5.1477 kg; the paper rounds to 0.043
    assert q.frequency_ratio == pytest.approx(ref.frequency_ratio, abs=5e-4)
    assert q.stiffness_ratio == 1.0


def test_normalized_parameters_validated():
    with pytest.raises(ParameterError) as exc:
        nz.NormalizedParams(excitation_amplitudes=(1.0, 2.0), excitation_phases=(0.0,))
    assert exc.value.name == 'excitation_phases'
    with pytest.raises(ParameterError) as exc:
        nz.NormalizedParams(damping_ratio=float('nan'))
    assert exc.value.name == 'damping_ratio' and 'finite' in exc.value.rule
    with pytest.raises(ParameterError) as exc:
        nz.NormalizedParams(damping_ratio=-0.1)
    assert exc.value.name == 'damping_ratio'
    with pytest.raises(TypeError):
        nz.NormalizedParams(zeta=0.1)  # type: ignore[call-arg]
