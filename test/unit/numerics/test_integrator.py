"""The RK4 hot loop: exact solution, convergence order, determinism, no-JIT run.

Independent references: the damped oscillator's closed-form solution (derived in the
docstring below), SciPy DOP853 through reference.solve, Richardson differences between
step sizes, and the same source run as plain Python (NUMBA_DISABLE_JIT=1). Contact
changes located inside steps through backlash impacts: test_contact_location.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from screwgear_ros.numerics.integrator import advance, trajectory
from screwgear_ros.numerics.reference import Segment, solve
from screwgear_ros.params.table import TableParams
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.packed import Drive, pack
from screwgear_ros.physics.quantities import equivalent_mass
from screwgear_ros.sim.plant import DriveInput

#: Table damping, N·m·s/rad, that makes the paper's 400 N·m drive run at the paper's steady
#: table speed: c_t = T1·(r2/r1) / ω2 with ω2 = (24 r/min)·r1/r2 = 0.337 rad/s.
PAPER_TABLE_DAMPING = 8867.0


def test_closed_form_damped_oscillator():
    """Constant stiffness, no STE, no backlash, one path, T_load = T1·r2/r1.

    With δ = r1θ1 − r2θ2 and F = k·δ + c·δ̇, §3 gives
        δ̈ = r1·θ̈1 − r2·θ̈2 = (r1²/I1 + r2²/I2)·(F_m − F),   F_m = T1/r1,
    because r1·T1/I1 + r2·T_load/I2 = F_m·(r1²/I1 + r2²/I2). So m_e·δ̈ + c·δ̇ + k·δ = F_m
    with 1/m_e = r1²/I1 + r2²/I2, whose solution is
        δ(t) = δ_s + e^(−ζω_n t)·(A·cos ω_d t + B·sin ω_d t),
        δ_s = F_m/k, A = δ(0) − δ_s, B = (δ̇(0) + ζω_n·A)/ω_d,
        ω_n = √(k/m_e), ζ = c/(2·m_e·ω_n), ω_d = ω_n·√(1 − ζ²).
    The table follows from I2·θ̈2 = r2·(F − F_m) = −r2·m_e·δ̈:
        θ2(t) = θ2(0) + ω2(0)·t − (r2·m_e/I2)·(δ(t) − δ(0) − δ̇(0)·t),
    i.e. the rigid mode keeps its speed (the drive and the load balance).
    """
    p = TableParams(mode='conventional', backlash=0.0, mesh_stiffness_amplitude=0.0,
                    ste_amplitudes=(), ste_phases=())
    m = pack(p)
    r1, r2, i2 = p.radius_pinion_1, p.radius_table, p.inertia_table
    torque = 400.0
    load = torque * r2 / r1
    me, k, c = equivalent_mass(p), p.mesh_stiffness_mean, p.mesh_damping
    wn = math.sqrt(k / me)
    zeta = c / (2 * me * wn)
    wd = wn * math.sqrt(1 - zeta ** 2)
    # start off equilibrium, with a rigid-body speed: δ(0) = 0.2 mm, δ̇(0) = −0.05 m/s
    th2_0, w2_0 = 0.01, 0.3
    delta0, rate0 = 2e-4, -0.05
    y = np.array([(delta0 + r2 * th2_0) / r1, th2_0, 0.0, (rate0 + r2 * w2_0) / r1, w2_0, 0.0])
    dt, stride, n = 5e-6, 20, 1000                       # 0.1 s, ~20 periods of 4.5 ms
    out = np.empty((n, 6))
    trajectory(y, 0, dt, stride, out, m, Drive(torque, 1.0, load))
    t = (np.arange(n) + 1) * stride * dt
    ds = (torque / r1) / k
    a = delta0 - ds
    b = (rate0 + zeta * wn * a) / wd
    delta_exact = ds + np.exp(-zeta * wn * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))
    th2_exact = th2_0 + w2_0 * t - r2 * me / i2 * (delta_exact - delta0 - rate0 * t)
    delta = r1 * out[:, 0] - r2 * out[:, 1]
    err_delta = np.max(np.abs(delta - delta_exact)) / np.max(np.abs(delta_exact))
    err_th2 = np.max(np.abs(out[:, 1] - th2_exact)) / np.max(np.abs(th2_exact))
    print(f'closed form, dt = 5 µs over 0.1 s: relative error δ {err_delta:.2e}, '
          f'θ2 {err_th2:.2e}')
    assert err_delta < 1e-9
    assert err_th2 < 1e-9
    assert np.all(out[:, 2] == 0.0) and np.all(out[:, 5] == 0.0)   # pinion 3 disengaged


def _paper_drive() -> tuple[TableParams, np.ndarray]:
    p = TableParams(table_damping=PAPER_TABLE_DAMPING)
    return p, equilibrium_state(p)


def test_rk4_convergence_order_on_the_3dof_model():
    """Order measured by halving dt: 200 → 100 → 50 µs, 400 N·m drive at the paper's speed.

    Errors are the maxima over 0.1 s (samples every 2 ms) per state component, against
    DOP853 (rtol 1e-11) and, independently of it, as Richardson differences. The default
    preload keeps both meshes in contact, so the right-hand side is smooth.
    """
    p, y0 = _paper_drive()
    m = pack(p)
    torque, sample, n = 400.0, 2e-3, 50
    steps_ref = (np.arange(n) + 1) * 2000                 # reference on a 1 µs step grid
    ref = solve(y0, [Segment(0, DriveInput(torque, 1, 0.0), p)], 1e-6, steps_ref)
    assert np.max(ref[:, 4]) > 0.3                                   # up to the paper's speed
    # smooth regime: both meshes stay on their flanks (δ1 > b, δ3 < −b, δ = rθ − r2θ2 − ε)
    eps = p.ste_amplitudes[0] * np.sin(24 * ref[:, [0, 2]])
    delta = p.radius_pinion_1 * ref[:, [0, 2]] - p.radius_table * ref[:, [1]] - eps
    assert np.all(delta[:, 0] > p.backlash) and np.all(delta[:, 1] < -p.backlash)
    runs = []
    for dt in (200e-6, 100e-6, 50e-6):
        y = y0.copy()
        out = np.empty((n, 6))
        trajectory(y, 0, dt, round(sample / dt), out, m, Drive(torque, 1.0, 0.0))
        runs.append(out)
    err = [np.max(np.abs(r - ref), axis=0) for r in runs]
    order_ref = [np.log2(err[i] / err[i + 1]) for i in range(2)]
    diff = [np.max(np.abs(runs[i] - runs[i + 1]), axis=0) for i in range(2)]
    order_richardson = np.log2(diff[0] / diff[1])
    print('order vs DOP853 (θ1 θ2 θ3 ω1 ω2 ω3):', *[np.round(o, 3) for o in order_ref])
    print('order by Richardson:', np.round(order_richardson, 3))
    for order in (*order_ref, order_richardson):
        assert np.all(np.abs(order - 4.0) <= 0.2), order


@pytest.mark.parametrize('mode', ['anti_backlash', 'conventional'])
@pytest.mark.parametrize('locate', [True, False], ids=['located', 'fixed step'])
def test_same_inputs_same_steps_give_bit_identical_states(mode, locate):
    """Two runs, and one run cut into different chunks, agree bit for bit (conventional:
    through backlash impacts, located or not)."""
    p = TableParams(table_damping=PAPER_TABLE_DAMPING, mode=mode)
    y0 = equilibrium_state(p)
    m = pack(p)
    schedule = [(0, 400.0, 1.0), (1234, 0.0, 1.0), (1500, 400.0, -1.0), (2999, 100.0, 1.0)]
    end = 4000

    def run(chunk: int) -> tuple[np.ndarray, int]:
        y = y0.copy()
        step = changes = 0
        for k, (start, torque, direction) in enumerate(schedule):
            stop = schedule[k + 1][0] if k + 1 < len(schedule) else end
            assert start == step
            while step < stop:
                n = min(chunk, stop - step)
                changes += advance(y, step, n, 50e-6, m, Drive(torque, direction, 0.0),
                                   locate)
                step += n
        return y, changes

    (a, changes), (b, _), (c, changes_c) = run(4000), run(4000), run(7)
    assert np.array_equal(a, b)
    assert np.array_equal(a, c) and changes == changes_c
    assert np.all(np.isfinite(a)) and not np.array_equal(a, y0)
    assert (changes > 0) == (locate and mode == 'conventional')


NO_JIT_SCRIPT = r'''
import json, sys
import numba
from screwgear_ros.numerics.integrator import advance
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.packed import Drive, pack
from screwgear_ros.params.table import TableParams
assert numba.config.DISABLE_JIT and not hasattr(advance, 'py_func'), 'JIT still on'
mode, locate = sys.argv[1], sys.argv[2] == 'located'
p = TableParams(table_damping=8867.0, ste_phases=(0.4,), mode=mode)
m = pack(p)
y = equilibrium_state(p)
changes = advance(y, 0, 600, 50e-6, m, Drive(400.0, 1.0, 0.0), locate)
changes += advance(y, 600, 600, 50e-6, m, Drive(400.0, -1.0, 5.0), locate)
json.dump([[float(v) for v in y], changes], sys.stdout)
'''


@pytest.mark.ros
@pytest.mark.parametrize('mode, locate', [('anti_backlash', 'located'),
                                          ('conventional', 'located'),
                                          ('conventional', 'fixed')])
def test_no_jit_runs_the_same_source_with_the_same_results(mode, locate):
    """The same source as plain Python; conventional: through the impacts of a reversal
    (a contact change located in plain Python too)."""
    env = dict(os.environ, NUMBA_DISABLE_JIT='1')
    proc = subprocess.run([sys.executable, '-P', '-c', NO_JIT_SCRIPT, mode, locate], env=env,
                          capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    plain, plain_changes = json.loads(proc.stdout)
    p = TableParams(table_damping=PAPER_TABLE_DAMPING, ste_phases=(0.4,), mode=mode)
    m = pack(p)
    y = equilibrium_state(p)
    changes = advance(y, 0, 600, 50e-6, m, Drive(400.0, 1.0, 0.0), locate == 'located')
    changes += advance(y, 600, 600, 50e-6, m, Drive(400.0, -1.0, 5.0), locate == 'located')
    print(f'{mode}, {locate}: compiled vs plain Python, max |difference|:',
          np.max(np.abs(np.array(plain) - y)), f'({changes} contact changes located)')
    assert np.allclose(plain, y, rtol=1e-12, atol=1e-12)
    assert plain_changes == changes and (changes > 0) == (mode == 'conventional'
                                                         and locate == 'located')
