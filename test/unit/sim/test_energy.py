"""The energy audit and the drive's torque–speed line.

The audit (screwgear_ros.sim.energy) is checked on its own quadrature against closed forms,
then used on runs driven through a Session: with the `energy_consistent` mesh the
balance closes to RK4's accuracy, shrinking at RK4's order as dt halves, in both modes
with backlash, STE and stiffness fluctuation on; with the `paper` mesh it misses by an
amount that does not depend on dt and is exactly the work of the paper's mesh terms.
The drive line is checked against the closed-form terminal speed
(:func:`screwgear_ros.physics.quantities.terminal_speed`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from paths import DATA

from screwgear_ros.params.table import PAPER_PINION_SPEED, SimSettings, TableParams
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.quantities import natural_frequency, terminal_speed
from screwgear_ros.sim import energy
from screwgear_ros.sim.events import Command, ParameterChange
from screwgear_ros.sim.run_file import RunParameters, dump, load
from screwgear_ros.sim.session import Session

R1, R2 = 0.078, 0.582
PAPER_TABLE_SPEED = PAPER_PINION_SPEED * R1 / R2      # 0.3368 rad/s
PAPER_TABLE_DAMPING = 8867.0                          # 400 N·m holds 0.3366 rad/s
DTS = (80e-6, 40e-6, 20e-6)
DURATION = 3.0                                        # s


# ---------------------------------------------------------------- quadrature

def test_quadrature_is_exact_for_quintics_and_sixth_order_beyond():
    t = np.linspace(0.0, 1.3, 14)
    h = t[1] - t[0]
    poly = np.polynomial.Polynomial([0.3, -1.0, 2.0, 0.5, -0.7, 1.1])
    np.testing.assert_allclose(energy.cumulative(poly(t), h), poly.integ()(t) - poly.integ()(0),
                               rtol=1e-13, atol=1e-14)
    errors = []
    for n in (200, 400):                              # ω·h = 0.2, 0.1 over ~13 periods
        t = np.linspace(0.0, 80.0, 4 * n + 1)
        exact = (1.0 - np.cos(t)) + 0.3 * t
        errors.append(np.max(np.abs(energy.cumulative(np.sin(t) + 0.3, t[1] - t[0]) - exact)))
    assert 2 ** 5.5 < errors[0] / errors[1] < 2 ** 6.5
    assert energy.cumulative(np.array([1.0, 3.0]), 0.5)[1] == 1.0      # two samples: trapezoid


# ---------------------------------------------------------------- runs

def _spinning(p: TableParams) -> np.ndarray:
    """The rest state, every body turning at the paper's speed (rigid kinematics)."""
    y = equilibrium_state(p)
    y[3:] = (PAPER_PINION_SPEED, PAPER_TABLE_SPEED, PAPER_PINION_SPEED)
    return y


def free_run(form: str, dt: float, **changes) -> energy.EnergyAudit:
    """Anti-backlash gear coasting at the paper's speed: no drive, no load, no table
    damping; preload, backlash, STE, k_a and mesh damping on (the default set)."""
    p = TableParams(mesh_formulation=form, **changes)
    return energy.run(p, dt, DURATION, initial_state=_spinning(p))


def driven_anti_backlash(form: str, dt: float) -> energy.EnergyAudit:
    """400 N·m forward against a 500 N·m load and c_t, reversed half way."""
    p = TableParams(mesh_formulation=form, table_damping=PAPER_TABLE_DAMPING)
    return energy.run(p, dt, DURATION, [(0.0, Command('cmd_torque', 400.0)),
                                        (0.0, Command('load_torque', 500.0)),
                                        (DURATION / 2, Command('cmd_direction', -1))])


def driven_conventional(form: str, dt: float) -> energy.EnergyAudit:
    """One pinion with backlash, 400 N·m + a 40 N·m torque fluctuation, load and c_t:
    mesh 1 closes its gap at the start and stays on its flank."""
    p = TableParams(mesh_formulation=form, mode='conventional', preload_torque=0.0,
                    table_damping=PAPER_TABLE_DAMPING, torque_fluctuation_amplitude=40.0,
                    torque_fluctuation_frequency=30.0)
    return energy.run(p, dt, DURATION, [(0.0, Command('cmd_torque', 400.0)),
                                        (0.0, Command('load_torque', 500.0))])


RUNS = {'free': free_run, 'anti_backlash': driven_anti_backlash,
        'conventional': driven_conventional}


@pytest.mark.parametrize('name', list(RUNS))
def test_the_energy_consistent_balance_closes_at_rk4s_order(name):
    """≤ 1e-6 relative at 20 µs over 3 s, and 2^3.4 to 2^4.6 smaller per halving of dt
    (measured: 2^3.5–2^3.9 at 40 → 20 µs, 1e-10 relative at 20 µs)."""
    audits = [RUNS[name]('energy_consistent', dt) for dt in DTS]
    misses = [float(np.max(np.abs(a.residual))) for a in audits]
    orders = np.log2(np.array(misses[:-1]) / np.array(misses[1:]))
    print(name, 'relative residual', [f'{a.relative_residual:.2e}' for a in audits],
          'orders', np.round(orders, 2), 'scale', audits[-1].scale, 'J')
    assert audits[-1].relative_residual <= 1e-6
    assert 3.4 <= orders[-1] <= 4.6 and orders[0] >= 3.0
    a = audits[-1]
    assert np.all(a.mesh_damping >= -1e-12) and np.all(a.work['viscous'] <= 0.0)
    if name != 'free':          # every term of the balance is at work
        assert min(abs(a.work['drive'][-1]), abs(a.work['load'][-1]), -a.work['viscous'][-1],
                   a.mesh_damping[-1]) > 1e-3 * a.scale
    if name != 'conventional':  # the preload's work, in the drives'
        assert abs(a.work['drive'][-1]) > 0.0


def test_the_paper_formulation_misses_and_its_miss_does_not_shrink_with_dt():
    """The same free run with the paper's mesh: the miss is the work of its own mesh
    terms ∫(½·K'·f² − F·ε')·z·ω dt (to integration accuracy) and the same at every dt."""
    audits = [free_run('paper', dt) for dt in DTS[1:]]
    for a in audits:
        assert np.max(np.abs(a.residual - a.phase_work)) <= 1e-6 * a.scale
    coarse, fine = audits
    print('paper, free run: relative miss', coarse.relative_residual, fine.relative_residual,
          'final', fine.residual[-1], 'J of', fine.scale, 'J')
    assert fine.relative_residual > 0.1
    assert abs(coarse.relative_residual / fine.relative_residual - 1.0) < 1e-4
    # without the STE (k_a alone) the paper's mesh swings the energy by
    # ≈ 2·(½·2k_a·f²), f = T_p/(r·k_m): the preload's deflection
    plain = free_run('paper', DTS[-1], ste_amplitudes=(), ste_phases=())
    f = 350.0 / (R1 * 1e7)
    swing = np.ptp(plain.residual)
    print('paper, free run without STE: energy swing', swing, 'J')
    assert swing == pytest.approx(2 * 1e6 * f * f, rel=0.1)


@pytest.mark.parametrize('form', ['paper', 'energy_consistent'])
def test_in_time_phase_both_formulations_close_with_the_excitations_work(form):
    """`time` phase: the mesh is a prescribed excitation; its work is in the balance."""
    audits = [free_run(form, dt, mesh_phase='time') for dt in DTS[1:]]
    a = audits[-1]
    assert np.max(np.abs(a.excitation)) > 1e-3 * a.scale
    assert a.relative_residual <= 1e-6
    assert np.max(np.abs(audits[0].residual)) > 8.0 * np.max(np.abs(a.residual))


def test_a_parameter_change_is_counted_where_it_takes_effect():
    """Stiffer meshes from 0.5 s on: the stored energy steps there, the audit books it."""
    p = TableParams(mesh_formulation='energy_consistent')
    dt = 20e-6
    settings = energy.settings_for(dt)
    session = Session(p, settings, _spinning(p))
    change = ParameterChange(p.replace(mesh_stiffness_mean=1.3e7, mesh_damping=1000.0),
                             settings)
    a = energy.audit(energy.record(session, 50_000, {25_000: [change]}))
    assert abs(a.retuning[-1]) > 0.1 and a.retuning[25_000] == 0.0
    assert a.relative_residual <= 1e-6


# ---------------------------------------------------------------- the drive line

def _steady(p: TableParams, torque: float, seconds: float = 2.5,
            mean_over: float = 0.5) -> tuple[float, float]:
    """Mean pinion speed over whole tooth periods in the last ``mean_over`` s, and the
    largest table speed there, rad/s, of a constant forward command from rest (a
    Session, 1 ms ticks). The steady state repeats with the tooth (φ = z1·θ1), so the mean
    is taken between the first and last instants at which φ passes a multiple of 2π
    (linear interpolation between ticks)."""
    settings = SimSettings(command_timeout=0.0)
    session = Session(p, settings)
    session.submit(Command('cmd_torque', torque))
    ticks = round(seconds * settings.publish_rate)
    last = round(mean_over * settings.publish_rate)
    time, theta, table = [], [], []
    for _ in range(ticks):
        out = session.tick().outputs
        time.append(out.time)
        theta.append(out.position[0])
        table.append(out.velocity[1])
    assert session.plant.fault is None
    t, turns = np.array(time[-last:]), np.array(theta[-last:]) * p.teeth_pinion_1 / (2 * np.pi)
    k = np.flatnonzero(np.floor(turns[1:]) > np.floor(turns[:-1]))     # crossing in (k, k+1)
    assert len(k) >= 3, 'fewer than two tooth periods in the window'
    level = np.floor(turns[k + 1])
    crossing = t[k] + (level - turns[k]) / (turns[k + 1] - turns[k]) * (t[k + 1] - t[k])
    periods = level[-1] - level[0]
    mean = periods * 2 * np.pi / p.teeth_pinion_1 / (crossing[-1] - crossing[0])
    return float(mean), max(table[-last:])


@pytest.mark.parametrize('torque, damping', [(400.0, 0.0), (100.0, 0.0), (400.0, 500.0),
                                             (400.0, PAPER_TABLE_DAMPING)])
def test_the_terminal_speed_is_the_closed_form(torque, damping):
    """A realistic STE (20 µm) keeps the speed ripple (±0.4 rad/s at ω_nl) on one piece
    of the line, where the closed form is the exact mean speed (`paper` mesh). c_t = 0:
    any command ends at ω_nl; c_t = 500: on the line; c_t = 8867: the paper's operating
    point, below the corner, as with the ideal source."""
    p = TableParams(ste_amplitudes=(20e-6,), table_damping=damping)
    expected = terminal_speed(p, torque)
    mean, _ = _steady(p, torque, seconds=4.0 if torque < 400 else 2.5)
    print(f'{torque} N·m, c_t = {damping}: mean {mean:.6f}, closed form {expected:.6f} rad/s')
    assert mean == pytest.approx(expected, rel=1e-5)
    if damping == 0.0:
        assert expected == pytest.approx(p.drive_no_load_speed, rel=1e-14)
    if damping == PAPER_TABLE_DAMPING:
        assert expected * R1 / R2 == pytest.approx(0.3366, abs=1e-4)
        assert expected < p.drive_no_load_speed * (1 - torque / p.drive_stall_torque)


def test_the_default_drive_cannot_run_the_table_into_the_mesh_resonance():
    """Default parameters (the paper's ε_1 = 1.54 mm, c_t = 0): max_torque ends near ω_nl
    (table ≈ 3.4 rad/s, mesh frequency z1·ω1 ≈ 0.42·ω0), far from the resonance
    z1·ω1 = ω0 (table ≈ 8 rad/s); with this STE the meshes rattle there and the mean
    falls a few % short of the closed form. The issue's 10 N·m, which ran away with the
    ideal source, stops lower still: the rattling mesh's damping takes its power."""
    p = TableParams()
    resonance_table_speed = natural_frequency(p) / p.teeth_pinion_1 * R1 / R2
    for torque in (p.max_torque, 10.0):
        mean, fastest = _steady(p, torque, seconds=4.0)
        print(f'{torque} N·m: mean pinion speed {mean:.3f} rad/s (closed form '
              f'{terminal_speed(p, torque):.3f}), table at most {fastest:.3f} rad/s, '
              f'resonance at {resonance_table_speed:.2f} rad/s')
        assert mean < 1.001 * p.drive_no_load_speed
        assert fastest < 0.6 * resonance_table_speed
        if torque == p.max_torque:
            assert mean > 0.9 * terminal_speed(p, torque)
    assert math.isinf(terminal_speed(p.replace(drive_no_load_speed=0.0), 400.0))


def test_recordings_from_before_the_drive_line_replay_with_the_ideal_source():
    """A run_parameters document without the new keys loads with the ideal torque source
    and the paper's equations; the checked-in bags are such recordings."""
    from screwgear_ros.bag.reader import read_run
    p = TableParams()
    text = dump(RunParameters(p, SimSettings(), tuple(equilibrium_state(p)),
                              package_version='0.1.0'))       # a version before the drive line
    new = ('drive_no_load_speed', 'drive_stall_torque', 'mesh_formulation')
    old = '\n'.join(line for line in text.splitlines() if not line.startswith(new))
    assert load(text).params == p
    assert load(old).params.drive_no_load_speed == 0.0
    assert load(old).params.mesh_formulation == 'paper'
    for name in ('steady_drive', 'reversals_conventional'):
        params = read_run(DATA / name).parameters.params
        assert params.drive_no_load_speed == 0.0 and params.mesh_formulation == 'paper'


def test_the_balance_closes_with_lagged_drives_and_cogging():
    """The drive's work is that of the torques actually applied: with 1 ms current loops
    (both drives working while a reversal hands over) and a cogging ripple the
    energy-consistent balance still closes at RK4's order."""
    def lagged(dt: float) -> energy.EnergyAudit:
        p = TableParams(mesh_formulation='energy_consistent', table_damping=PAPER_TABLE_DAMPING,
                        drive_time_constant=1e-3, cogging_amplitude=3.0, cogging_order=6)
        return energy.run(p, dt, DURATION, [(0.0, Command('cmd_torque', 400.0)),
                                            (0.0, Command('load_torque', 500.0)),
                                            (DURATION / 2, Command('cmd_direction', -1))])
    audits = [lagged(dt) for dt in DTS]
    misses = [float(np.max(np.abs(a.residual))) for a in audits]
    print('lagged relative residual', [f'{a.relative_residual:.2e}' for a in audits])
    assert audits[-1].relative_residual <= 1e-6
    assert np.log2(misses[-2] / misses[-1]) >= 3.4
