"""The 3-DOF model's pieces against model.md written out independently here.

Mesh force law (§2) case by case, STE and mesh-rate derivatives against finite
differences, drive torques per mode and direction (§4), the equations of motion
against hand-assembled Newton equations (§3), and the static preload equilibrium.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from model_laws import drive_line, mesh_load, mesh_state

from screwgear_ros.numerics.integrator import advance
from screwgear_ros.params.table import TableParams
from screwgear_ros.physics.drive import active_path, applied_torques, drive_torques
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.mesh import mesh_force, mesh_stiffness, static_transmission_error
from screwgear_ros.physics.motion import rhs
from screwgear_ros.physics.packed import R1, Z1, Drive, pack

K, C = 1.1e7, 717.0   # a mesh stiffness (N/m) and damping (N·s/m) for the force-law cases


# ---------------------------------------------------------------- mesh force law (§2)

@pytest.mark.parametrize('delta, rate', [(3e-4, 0.0), (-2e-5, 0.01), (0.0, -0.3), (1e-9, 1e-6)])
def test_force_without_backlash_is_linear(delta, rate):
    """b = 0: F = K·δ + c·δ̇, pulling and pushing alike."""
    assert mesh_force(delta, rate, K, C, 0.0) == pytest.approx(K * delta + C * rate, rel=1e-15)


@pytest.mark.parametrize('delta', [0.0, 5e-5, -5e-5, 75e-6, -75e-6])
@pytest.mark.parametrize('rate', [0.0, 2.0, -2.0])
def test_no_force_inside_the_gap(delta, rate):
    """|δ| ≤ b: no contact, no spring, no damping, whatever the rate."""
    assert mesh_force(delta, rate, K, C, 75e-6) == 0.0


def test_contact_spring_acts_on_penetration_and_damping_only_in_contact():
    b = 75e-6
    assert mesh_force(b + 1e-5, 0.0, K, C, b) == pytest.approx(K * 1e-5, rel=1e-12)
    assert mesh_force(-b - 1e-5, 0.0, K, C, b) == pytest.approx(-K * 1e-5, rel=1e-12)
    # closing in contact: damping adds to the spring force
    assert mesh_force(b + 1e-5, 0.05, K, C, b) == pytest.approx(K * 1e-5 + C * 0.05, rel=1e-12)
    assert mesh_force(-b - 1e-5, -0.05, K, C, b) == pytest.approx(-K * 1e-5 - C * 0.05,
                                                                    rel=1e-12)
    # the penetration force is continuous at the flank (zero just inside and just outside)
    assert mesh_force(b * (1 + 1e-12), 0.0, K, C, b) == pytest.approx(0.0, abs=1e-9)


def test_contact_force_never_pulls():
    """Separating fast in contact: K·(δ − b) + c·δ̇ < 0 would pull the flanks together."""
    b = 75e-6
    assert K * 1e-6 + C * (-1.0) < 0.0
    assert mesh_force(b + 1e-6, -1.0, K, C, b) == 0.0
    assert mesh_force(-b - 1e-6, +1.0, K, C, b) == 0.0
    rng = np.random.default_rng(7)
    for delta, rate in zip(rng.uniform(-1e-3, 1e-3, 2000), rng.uniform(-5.0, 5.0, 2000), strict=True):
        f = mesh_force(delta, rate, K, C, b)
        if delta > b:
            assert f >= 0.0
        elif delta < -b:
            assert f <= 0.0
        else:
            assert f == 0.0


def test_mesh_stiffness_law():
    p = TableParams(mesh_stiffness_phase=0.4, thermal_coefficient=1e-3, temperature_rise=20.0,
                    preload_stiffness=5e5)
    m = pack(p)
    k_eff = 1e7 * (1 - 0.02) + 5e5
    for phi in np.linspace(-7.0, 7.0, 29):
        assert mesh_stiffness(phi, m.p) == pytest.approx(k_eff + 1e6 * math.cos(phi + 0.4),
                                                         rel=1e-14)


# ---------------------------------------------------------------- STE and rates

def test_ste_and_its_derivative_against_finite_differences():
    amp = np.array([1.5e-3, 2e-4, -7e-5])
    phase = np.array([0.3, -1.1, 2.0])
    h = 1e-5
    for phi in np.linspace(-4.0, 4.0, 33):
        eps, deps = static_transmission_error(phi, amp, phase)
        assert eps == pytest.approx(sum(a * math.sin((n + 1) * phi + ph)
                                        for n, (a, ph) in enumerate(zip(amp, phase, strict=False))),
                                    abs=1e-18)
        fd = (static_transmission_error(phi + h, amp, phase)[0]
              - static_transmission_error(phi - h, amp, phase)[0]) / (2 * h)
        # central difference error ~ h²/6·|ε'''| ≤ 1e-10·Σ|ε_n|·n³
        assert deps == pytest.approx(fd, abs=1e-12)
    assert static_transmission_error(1.0, np.empty(0), np.empty(0)) == (0.0, 0.0)


@pytest.mark.parametrize('mesh_phase', ['angle', 'time'])
def test_transmission_error_rate_is_the_time_derivative(mesh_phase):
    """δ̇ from mesh_state = d/dt of δ along a motion at constant speeds (central differences)."""
    p = TableParams(mesh_phase=mesh_phase, ste_amplitudes=(1.5e-3, 3e-4), ste_phases=(0.2, 1.0))
    m = pack(p)
    th1, w1, th2, w2, t = 0.37, 2.6, 0.05, 0.33, 0.123

    def delta(s: float) -> float:
        return mesh_state(th1 + w1 * s, w1, m.p[R1], m.p[Z1], th2 + w2 * s, w2, t + s,
                          m)[0]

    h = 1e-6
    fd = (delta(h) - delta(-h)) / (2 * h)
    rate = mesh_state(th1, w1, m.p[R1], m.p[Z1], th2, w2, t, m)[1]
    assert rate == pytest.approx(fd, rel=1e-7)
    # and δ itself is r1·θ1 − r2·θ2 − ε(φ), φ = z1·θ1 (angle) or ω_e·t (time)
    phi = 24 * th1 if mesh_phase == 'angle' else p.mesh_frequency * t
    eps = 1.5e-3 * math.sin(phi + 0.2) + 3e-4 * math.sin(2 * phi + 1.0)
    assert delta(0.0) == pytest.approx(0.078 * th1 - 0.582 * th2 - eps, abs=1e-17)


# ---------------------------------------------------------------- drive torques (§4)

@pytest.mark.parametrize('direction, expected', [(1.0, (350.0 + 120.0, -350.0)),
                                                 (-1.0, (350.0, -350.0 - 120.0))])
def test_anti_backlash_drive_torques(direction, expected):
    m = pack(TableParams())
    assert drive_torques(0.3, 120.0, direction, m.p) == pytest.approx(expected, rel=1e-15)
    assert drive_torques(0.3, 0.0, direction, m.p) == (350.0, -350.0)


@pytest.mark.parametrize('direction', [1.0, -1.0])
def test_conventional_drive_torques(direction):
    m = pack(TableParams(mode='conventional'))
    assert drive_torques(0.3, 120.0, direction, m.p) == (direction * 120.0, 0.0)


def test_torque_fluctuation_rides_on_the_active_path():
    m_ab = pack(TableParams(torque_fluctuation_amplitude=30.0, torque_fluctuation_frequency=50.0))
    m_cv = pack(TableParams(mode='conventional', torque_fluctuation_amplitude=30.0,
                            torque_fluctuation_frequency=50.0))
    t = 0.0123
    drive = 100.0 + 30.0 * math.sin(50.0 * t)
    assert drive_torques(t, 100.0, 1.0, m_ab.p) == pytest.approx((350.0 + drive, -350.0))
    assert drive_torques(t, 100.0, -1.0, m_ab.p) == pytest.approx((350.0, -350.0 - drive))
    assert drive_torques(t, 100.0, -1.0, m_cv.p) == pytest.approx((-drive, 0.0))


def test_active_path():
    assert active_path('anti_backlash', 1) == 1
    assert active_path('anti_backlash', -1) == 3
    assert active_path('conventional', 1) == 1
    assert active_path('conventional', -1) == 1


# ---------------------------------------------------------------- equations of motion (§3)

@pytest.mark.parametrize('mode', ['anti_backlash', 'conventional'])
def test_rhs_is_newtons_equations(mode):
    """Accelerations from hand-assembled forces: I1·θ̈1 = T1 − r1F1, I3·θ̈3 = T3 − r3F3,
    I2·θ̈2 = r2(F1 + F3) − T_load − c_t·θ̇2 (F3 = 0 in conventional mode)."""
    p = TableParams(mode=mode, table_damping=120.0, backlash=2e-5, ste_phases=(0.5,))
    m = pack(p)
    y = (0.013, 0.0004, -0.009, 2.1, 0.27, 1.9, 0.0, 0.0)     # no current-loop lag
    t, torque, direction, load = 0.017, 250.0, -1.0, 33.0
    out = rhs(t, y, m, Drive(torque, direction, load))

    def force(theta, omega, r):
        eps = 1.5384e-3 * math.sin(24 * theta + 0.5)
        deps = 1.5384e-3 * 24 * math.cos(24 * theta + 0.5) * omega
        d = r * theta - 0.582 * y[1] - eps
        dd = r * omega - 0.582 * y[4] - deps
        k = 1e7 + 1e6 * math.cos(24 * theta)
        if abs(d) <= 2e-5:
            return 0.0
        f = k * (d - math.copysign(2e-5, d)) + p.mesh_damping * dd
        return max(f, 0.0) if d > 0 else min(f, 0.0)

    f1 = force(y[0], y[3], 0.078)
    f3 = force(y[2], y[5], 0.078) if mode == 'anti_backlash' else 0.0
    if mode == 'anti_backlash':
        t1, t3 = 350.0, -350.0 - torque
    else:
        t1, t3 = -torque, 0.0
    expected = (y[3], y[4], y[5], (t1 - 0.078 * f1) / 3.255e-2,
                (0.582 * (f1 + f3) - load - 120.0 * y[4]) / 46.101, (t3 - 0.078 * f3) / 3.255e-2,
                0.0, 0.0)
    assert out == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert f1 != 0.0 and (mode == 'conventional' or f3 != 0.0)


# ---------------------------------------------------------------- static equilibrium

EQUILIBRIUM_CASES = [
    {},
    {'ste_phases': (0.7,), 'mesh_stiffness_phase': 1.1},
    {'ste_amplitudes': (1e-3, 2e-4, 5e-5), 'ste_phases': (0.3, 1.2, -2.0)},
    {'backlash': 0.0, 'ste_phases': (0.7,)},
    {'preload_stiffness': 2e6, 'thermal_coefficient': 1e-3, 'temperature_rise': 30.0,
     'ste_phases': (0.4,)},
    {'mode': 'conventional', 'ste_phases': (0.7,)},
    # `time` phase: K and ε follow t, so rest is an equilibrium only while ω_e = 0
    {'mesh_phase': 'time', 'mesh_frequency': 0.0, 'ste_phases': (0.7,),
     'mesh_stiffness_phase': 1.1},
    {'mesh_phase': 'time', 'mesh_frequency': 0.0, 'ste_phases': (0.7,), 'mode': 'conventional'},
]


@pytest.mark.parametrize('changes', EQUILIBRIUM_CASES, ids=lambda c: ','.join(c) or 'default')
def test_equilibrium_under_preload_does_not_move(changes):
    p = TableParams(**changes)
    m = pack(p)
    y0 = equilibrium_state(p)
    assert y0[1] == 0.0 and np.all(y0[3:] == 0.0)
    # the mesh deflections model.md §4 asks for, computed here from δ = r·θ − r2·θ2 − ε
    phi1 = 24 * y0[0] if p.mesh_phase == 'angle' else 0.0
    phi3 = 24 * y0[2] if p.mesh_phase == 'angle' else 0.0
    amp, ph = np.array(p.ste_amplitudes), np.array(p.ste_phases)
    n = np.arange(1, len(amp) + 1)
    d1 = 0.078 * y0[0] - float(np.sum(amp * np.sin(n * phi1 + ph)))
    d3 = 0.078 * y0[2] - float(np.sum(amp * np.sin(n * phi3 + ph)))
    tp = p.preload_torque if p.mode == 'anti_backlash' else 0.0
    k1 = mesh_stiffness(phi1, m.p)
    k3 = mesh_stiffness(phi3, m.p)
    assert d1 == pytest.approx(p.backlash + tp / (0.078 * k1), rel=1e-12, abs=1e-18)
    assert d3 == pytest.approx(-p.backlash - tp / (0.078 * k3), rel=1e-12, abs=1e-18)
    # no command for 1 s at the default step: nothing moves
    y = y0.copy()
    advance(y, 0, 20000, 50e-6, m, Drive(0.0, 1.0, 0.0))
    assert np.max(np.abs(y - y0)) <= 1e-12
    # also after a step count that is not zero (`time` phase sees t = step·dt)
    advance(y, 10**7, 2000, 50e-6, m, Drive(0.0, -1.0, 0.0))
    assert np.max(np.abs(y - y0)) <= 1e-12


# ---------------------------------------------------------------- mesh formulation

def _potential(p: TableParams, theta: float, theta2: float, radius: float) -> float:
    """½·K(φ)·f(δ)² of one mesh in `angle` phase, written out from model.md §2."""
    phi = 24 * theta
    eps = sum(a * math.sin((n + 1) * phi + ph)
              for n, (a, ph) in enumerate(zip(p.ste_amplitudes, p.ste_phases, strict=False)))
    delta = radius * theta - 0.582 * theta2 - eps
    b = p.backlash
    f = 0.0 if abs(delta) <= b else delta - math.copysign(b, delta)
    k = 1e7 + p.mesh_stiffness_amplitude * math.cos(phi + p.mesh_stiffness_phase)
    return 0.5 * k * f * f


@pytest.mark.parametrize('theta1', [0.013, 0.051, -0.2, 0.3])
def test_energy_consistent_mesh_forces_are_the_gradient_of_the_mesh_potential(theta1):
    """Without damping, Q = ∂V/∂θ on the pinion and −r2·F = ∂V/∂θ2 on the table, with
    V = ½·K(zθ)·f(δ)², by central differences (the derivation of model_notes §9)."""
    p = TableParams(mesh_formulation='energy_consistent', mesh_damping=0.0,
                    ste_amplitudes=(1.5e-3, 2e-4), ste_phases=(0.4, -1.0),
                    mesh_stiffness_phase=0.7)
    m = pack(p)
    theta2 = -0.0004
    force, load = mesh_load(theta1, 2.0, 0.078, 24.0, theta2, 0.3, 0.0, m)
    h = 1e-7
    dv1 = (_potential(p, theta1 + h, theta2, 0.078)
           - _potential(p, theta1 - h, theta2, 0.078)) / (2 * h)
    dv2 = (_potential(p, theta1, theta2 + h, 0.078)
           - _potential(p, theta1, theta2 - h, 0.078)) / (2 * h)
    assert load == pytest.approx(dv1, rel=1e-7)
    assert -0.582 * force == pytest.approx(dv2, rel=1e-7)
    # the paper's pinion load is r·F, which is not the gradient of V
    paper = pack(p.replace(mesh_formulation='paper'))
    _, paper_load = mesh_load(theta1, 2.0, 0.078, 24.0, theta2, 0.3, 0.0, paper)
    assert paper_load == pytest.approx(0.078 * force, rel=1e-15)
    assert abs(paper_load - dv1) > 1e-3 * abs(dv1)


def test_energy_consistent_damping_acts_along_the_lever():
    """The contact damping c·δ̇ is a force along δ: on the pinion through ∂δ/∂θ = r − z·ε'."""
    p = TableParams(mesh_formulation='energy_consistent', backlash=0.0)
    undamped = pack(p.replace(mesh_damping=0.0))
    m = pack(p)
    args = (0.021, 2.4, 0.078, 24.0, 0.001, 0.31, 0.0)
    f0, q0 = mesh_load(*args, undamped)
    f, q = mesh_load(*args, m)
    rate = mesh_state(*args, m)[1]
    lever = 0.078 - 24 * 1.5384e-3 * math.cos(24 * 0.021)
    assert f - f0 == pytest.approx(p.mesh_damping * rate, rel=1e-9)
    assert q - q0 == pytest.approx(lever * p.mesh_damping * rate, rel=1e-9)


@pytest.mark.parametrize('mode', ['anti_backlash', 'conventional'])
def test_both_formulations_are_the_same_equations_in_time_phase(mode):
    y = (0.013, 0.0004, -0.009, 2.1, 0.27, 1.9, 0.0, 0.0)     # no current-loop lag
    out = []
    for form in ('paper', 'energy_consistent'):
        m = pack(TableParams(mode=mode, mesh_phase='time', mesh_formulation=form,
                             preload_torque=0.0 if mode == 'conventional' else 350.0))
        out.append(rhs(0.017, y, m, Drive(250.0, 1.0, 33.0)))
    assert out[0] == out[1]


ENERGY_EQUILIBRIUM_CASES = [
    {},
    {'ste_phases': (0.7,), 'mesh_stiffness_phase': 1.1},
    {'ste_amplitudes': (1e-3, 2e-4, 5e-5), 'ste_phases': (0.3, 1.2, -2.0)},
    {'backlash': 0.0, 'ste_phases': (2.5,)},
    {'ste_amplitudes': (20e-6,)},          # θ2 = 0 is a cogging maximum here: moves on
    {'ste_amplitudes': (20e-6,), 'ste_phases': (2.5,), 'preload_stiffness': 2e6},
]


@pytest.mark.parametrize('changes', ENERGY_EQUILIBRIUM_CASES,
                         ids=lambda c: ','.join(c) or 'default')
def test_energy_consistent_equilibrium_is_a_stable_rest(changes):
    """The preload's static balance with the energy-consistent mesh: each pinion's mesh
    load is ±T_p, the table carries no torque, nothing moves for 1 s, and a small table
    displacement (pinions re-balanced) meets a restoring torque (a stable rest)."""
    p = TableParams(mesh_formulation='energy_consistent', **changes)
    m = pack(p)
    y0 = equilibrium_state(p)
    assert np.all(y0[3:] == 0.0)
    f1, q1 = mesh_load(y0[0], 0.0, 0.078, 24.0, y0[1], 0.0, 0.0, m)
    f3, q3 = mesh_load(y0[2], 0.0, 0.078, 24.0, y0[1], 0.0, 0.0, m)
    assert q1 == pytest.approx(350.0, rel=1e-12) and q3 == pytest.approx(-350.0, rel=1e-12)
    assert abs(f1 + f3) < 1e-9 * abs(f1)
    y = y0.copy()
    advance(y, 0, 20000, 50e-6, m, Drive(0.0, 1.0, 0.0))
    assert np.max(np.abs(y - y0)) <= 1e-12
    # restoring: shift the table by ±1 µrad and solve the pinions again (static, by
    # bisection on each pinion's own balance, independent of the model's Newton)
    def table_force(theta2: float) -> float:
        total = 0.0
        for index, sign in ((0, 1.0), (2, -1.0)):
            lo, hi = y0[index] - 2e-3, y0[index] + 2e-3
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                q = mesh_load(mid, 0.0, 0.078, 24.0, theta2, 0.0, 0.0, m)[1]
                lo, hi = (mid, hi) if q < sign * 350.0 else (lo, mid)
            total += mesh_load(lo, 0.0, 0.078, 24.0, theta2, 0.0, 0.0, m)[0]
        return total
    assert table_force(y0[1] + 1e-6) < 0.0 < table_force(y0[1] - 1e-6)


def test_paper_and_conventional_equilibria_do_not_depend_on_the_formulation():
    """No preload force, or `time` phase: the rest state is the paper's."""
    for changes in ({'mode': 'conventional', 'preload_torque': 0.0}, {'preload_torque': 0.0},
                    {'mesh_phase': 'time', 'mesh_frequency': 0.0}):
        p = TableParams(**changes)
        assert np.array_equal(equilibrium_state(p),
                              equilibrium_state(p.replace(mesh_formulation='energy_consistent')))


# ---------------------------------------------------------------- drive line

def test_drive_line_is_the_command_below_the_line_and_the_line_above():
    """T = min(T_cmd, T_s·(1 − ω/ω_nl)) for a nonzero command; ω_nl = 0: the command."""
    p = TableParams(drive_no_load_speed=20.0, drive_stall_torque=1000.0)
    m = pack(p)
    assert drive_line(400.0, 0.0, m.p) == 400.0
    assert drive_line(400.0, -50.0, m.p) == 400.0         # driven backwards: the command
    assert drive_line(400.0, 12.0, m.p) == 400.0          # corner at ω = 12 rad/s
    assert drive_line(400.0, 15.0, m.p) == pytest.approx(1000.0 * (1 - 15.0 / 20.0))
    assert drive_line(400.0, 20.0, m.p) == 0.0            # no-load speed
    assert drive_line(400.0, 25.0, m.p) == pytest.approx(-250.0)   # brakes beyond it
    assert drive_line(0.0, 25.0, m.p) == 0.0              # a zero command: drive off
    ideal = pack(p.replace(drive_no_load_speed=0.0))
    assert drive_line(400.0, 1e3, ideal.p) == 400.0


@pytest.mark.parametrize('mode, direction, speed', [
    ('anti_backlash', 1.0, 15.0), ('anti_backlash', -1.0, -7.0),
    ('conventional', 1.0, 15.0), ('conventional', -1.0, -15.0)])
def test_the_drive_line_sees_the_active_pinion_in_its_driving_sense(mode, direction, speed):
    """ω1 = 15, ω3 = 7 rad/s: path 1 runs forward at 15 rad/s, path 3 backwards at 7."""
    p = TableParams(mode=mode, preload_torque=0.0 if mode == 'conventional' else 350.0,
                    drive_no_load_speed=20.0, drive_stall_torque=1000.0,
                    torque_fluctuation_amplitude=30.0, torque_fluctuation_frequency=50.0)
    m = pack(p)
    t = 0.0123
    delivered = drive_line(400.0, speed, m.p)
    assert applied_torques(t, 15.0, 7.0, 400.0, direction, m.p) == \
        drive_torques(t, delivered, direction, m.p)
    assert delivered == (250.0 if speed == 15.0 else 400.0)
