"""The DOP853 reference solver, and the RK4 plant checked against it on the paper's case.

The reference (the compiled DOP853 of screwgear_ros.numerics.dop853, and SciPy's solve_ivp
DOP853 kept as an independent implementation) is first checked against the damped
oscillator's closed form (see test_integrator.test_closed_form_damped_oscillator for
the derivation) and the two against each other on the same segments, then used to
bound RK4's error at the node's default step. That bound is cross-checked by
Richardson's estimate from a run at twice the step, which does not use the reference.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from bag_runs import reversal_run

from screwgear_ros.numerics.reference import ATOL, RTOL, ReferenceFailure, Segment, solve
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.physics.quantities import equivalent_mass
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.plant import DriveInput, Plant

PAPER_TABLE_DAMPING = 8867.0   # N·m·s/rad: 400 N·m drives the table at 0.337 rad/s

#: RK4 error bounds at dt = 50 µs on the paper's case (400 N·m drive 0.3 s, then a 400 N·m
#: reversal 0.3 s, default parameters, c_t as above), each ~10× what was measured:
#: θ1, θ3 7e-9 / 9e-9 rad; θ2 7e-11 rad; ω1, ω3 1.0e-5 / 1.4e-5 rad/s; ω2 1.0e-7 rad/s;
#: δ1, δ3 6e-10 / 9e-10 m (on |δ| ~ 0.5 mm). The error scales as dt⁴ (order test).
BOUND_ANGLE_PINION = 1e-7       # rad
BOUND_ANGLE_TABLE = 1e-9        # rad
BOUND_SPEED_PINION = 1e-4       # rad/s
BOUND_SPEED_TABLE = 1e-6        # rad/s
BOUND_DELTA = 1e-8              # m


@pytest.mark.parametrize('method', ['dop853', 'scipy'])
def test_reference_matches_the_closed_form(method):
    p = TableParams(mode='conventional', backlash=0.0, mesh_stiffness_amplitude=0.0,
                    ste_amplitudes=(), ste_phases=())
    r1, r2 = p.radius_pinion_1, p.radius_table
    me, k, c = equivalent_mass(p), p.mesh_stiffness_mean, p.mesh_damping
    wn = math.sqrt(k / me)
    zeta = c / (2 * me * wn)
    wd = wn * math.sqrt(1 - zeta ** 2)
    torque = 400.0
    dt = 1e-5
    samples = np.arange(1, 51) * 200                  # every 2 ms to 0.1 s
    # start at rest with δ = 0; the load T1·r2/r1 is switched on with the drive at step 0
    seg = [Segment(0, DriveInput(torque, 1, torque * r2 / r1), p)]
    out = solve(np.zeros(6), seg, dt, samples, method=method)
    t = samples * dt
    ds = torque / r1 / k
    exact = ds - ds * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    delta = r1 * out[:, 0] - r2 * out[:, 1]
    assert np.max(np.abs(delta - exact)) / ds < 1e-9


def test_reference_segments_switch_input_at_their_step():
    """Inputs change exactly at Segment.start_step; samples may sit on the boundaries."""
    p = TableParams(table_damping=PAPER_TABLE_DAMPING)
    plant = Plant(p, 50e-6)
    y0 = plant.state.copy()
    segs = [Segment(0, DriveInput(0.0, 1, 0.0), p), Segment(100, DriveInput(300.0, 1, 0.0), p),
            Segment(300, DriveInput(300.0, -1, 20.0), p)]
    samples = np.array([0, 50, 100, 200, 300, 400])
    out = solve(y0, segs, 50e-6, samples)
    assert np.array_equal(out[0], y0)
    assert np.max(np.abs(out[1:3] - y0)) < 1e-12       # nothing moves before the drive
    assert out[3, 0] > y0[0] + 1e-3 and out[3, 1] > 0.0   # pinion 1 and table driven forward
    with pytest.raises(ValueError):
        solve(y0, [Segment(10, DriveInput(), p)], 50e-6, np.array([0, 20]))


@pytest.mark.parametrize('case', [
    {'table_damping': PAPER_TABLE_DAMPING},
    {'table_damping': PAPER_TABLE_DAMPING, 'mesh_formulation': 'energy_consistent'},
    {'mode': 'conventional', 'preload_torque': 0.0},          # backlash impacts
    {'mesh_phase': 'time', 'table_damping': 30.0, 'drive_no_load_speed': 0.0},
], ids=['paper', 'energy_consistent', 'conventional', 'time_phase_ideal_drive'])
def test_compiled_dop853_agrees_with_scipy_on_the_same_segments(case):
    """Two implementations of DOP853 on the same segments (a reversal and a load step,
    samples on the boundaries) agree within what the method guarantees each of them.

    Each solve is within its global error of the exact solution, so the two are within
    the sum of their global errors. Neither error is a fixed multiple of the tolerance:
    DOP853 controls the local error of each step, and where the contact law has a corner
    (a backlash impact, a contact lost) its error estimate no longer describes the step,
    so the global error depends on where the accepted steps happen to fall. Two solvers
    whose rounding differs in the last bit (another CPU, another NumPy kernel) accept
    different steps after such a corner and end up differing by about one such error
    (the conventional case: 7e-9 of the pinion's speed at rtol 1e-11, 60 times what
    the same solvers differ by on the smooth cases). Each solver therefore estimates
    its own global error by solving again at a hundredth of the tolerances. Through the
    corners the error does not shrink in proportion to the tolerance (at a tenth it
    sometimes shrank by less than half), but a hundred times tighter it is at least
    halved, so the error at the tolerance is at most twice the difference to that
    solve (e ≤ |y − y_fine| + e_fine, e_fine ≤ e/2). Hence per sample and state:
    |ours − SciPy| ≤ 2 (|ours − ours_fine| + |SciPy − SciPy_fine|), plus the finer
    solves' own relative tolerance of each signal's magnitude (below it nothing is
    resolved, e.g. at the first samples). This fails when the compiled solver is not
    DOP853 (a change of 1e-8 in one damping of its model fails it 600 to 4000 times over):
    it then disagrees with SciPy by more than either moves with the tolerance, whatever
    the CPU and whatever NumPy's and OpenBLAS's kernels for it.
    """
    p = TableParams(**case)
    dt = 50e-6
    y0 = Plant(p, dt).state.copy()
    segs = [Segment(0, DriveInput(400.0, 1, 0.0), p), Segment(2000, DriveInput(400.0, -1, 0.0), p),
            Segment(3000, DriveInput(400.0, -1, -150.0), p)]
    samples = np.arange(0, 4001, 20)
    fine = {'rtol': RTOL / 100, 'atol': ATOL / 100}
    ours = solve(y0, segs, dt, samples)
    scipy = solve(y0, segs, dt, samples, method='scipy')
    error = (np.abs(ours - solve(y0, segs, dt, samples, **fine))
             + np.abs(scipy - solve(y0, segs, dt, samples, method='scipy', **fine)))
    scale = np.maximum(np.max(np.abs(scipy), axis=0), 1e-3)  # pinion 3 idles in conventional
    bound = 2.0 * error + fine['rtol'] * scale
    worst = np.max(np.abs(ours - scipy) / bound, axis=0)
    print(case, 'max |compiled − SciPy| / bound per state:', worst,
          'estimated global error / max|y|:', np.max(error, axis=0) / scale)
    assert np.all(worst <= 1.0), worst
    # Both converged: the tolerance-sensitivity used as the bound is itself small.
    assert np.all(np.max(error, axis=0) < 1e-7 * scale), np.max(error, axis=0) / scale
    assert np.ptp(scipy[:, 4]) > 0.1                  # the table did move both ways


@pytest.mark.parametrize('method', ['dop853', 'scipy'])
def test_reference_gives_each_input_exactly_its_ticks_late_in_a_run(method):
    """The momentum the drive puts in, by the closed form, at every tick a minute into a run.

    With c_t = 0 and the `paper` mesh, I2·ω2 + (r2/r1)·I1·ω1 + (r2/r3)·I3·ω3 changes at
    (r2/r1)·T1 + (r2/r3)·T3 − T_load (the mesh forces are internal), constant over each
    tick: a linear invariant, which every Runge–Kutta step keeps to round-off. So the
    reference's momentum at each tick is the sum of these rates × n·dt over the ticks
    before it, whatever its steps, if it integrates each input for exactly its ticks.
    Counting steps on the absolute time instead (floats 7e-15 s apart there, 7e-12 of
    a tick) misses this by far more than round-off, and the table angle drifts.
    """
    p = TableParams()
    dt, n, first, ticks = 50e-6, 20, 930_000, 120
    r1, r2, r3 = p.radius_pinion_1, p.radius_table, p.radius_pinion_3
    rng = np.random.default_rng(7)
    torques = rng.uniform(0.0, 200.0, ticks)                 # a new command every tick
    directions = np.where(np.arange(ticks) < ticks // 2, 1, -1)   # and a reversal
    loads = rng.uniform(-50.0, 50.0, ticks)
    segs = [Segment(first + i * n, DriveInput(float(t), int(d), float(load)), p)
            for i, (t, d, load) in enumerate(zip(torques, directions, loads, strict=True))]
    # anti_backlash: T1 = T_p (+ the drive if d = +1), T3 = −T_p (− the drive if d = −1)
    t1 = p.preload_torque + np.where(directions > 0, torques, 0.0)
    t3 = -p.preload_torque - np.where(directions < 0, torques, 0.0)
    rate = r2 / r1 * t1 + r2 / r3 * t3 - loads
    samples = first + np.arange(ticks + 1) * n
    y0 = Plant(p, dt).state.copy()
    out = solve(y0, segs, dt, samples, method=method)

    def momentum(y):
        return (p.inertia_table * y[..., 4] + r2 / r1 * p.inertia_pinion_1 * y[..., 3]
                + r2 / r3 * p.inertia_pinion_3 * y[..., 5])
    expected = momentum(y0) + np.concatenate([[0.0], np.cumsum(rate * n * dt)])
    assert np.ptp(out[:, 5]) > 1.0                     # the reversal did swing pinion 3
    # ... and the drive stayed below its torque–speed line, where the rate is the command's
    assert np.abs(out[:, 3:6:2]).max() < p.drive_no_load_speed * (1.0 - 200.0 / p.drive_stall_torque)
    # round-off: a few units in the last place of the momentum per tick
    bound = 1e-14 * np.abs(rate).max() * n * dt * ticks
    error = np.abs(momentum(out) - expected)
    print(method, 'momentum off the closed form by', error.max(), 'of a bound', bound)
    assert error.max() < bound, (error.max(), bound)


def test_reference_failure_is_typed_and_located():
    """A state the model cannot continue from ends in ReferenceFailure, which says why,
    when and in which segment, never in an exception from inside the solver."""
    p = TableParams()
    y0 = Plant(p, 50e-6).state.copy()
    segs = [Segment(0, DriveInput(100.0, 1, 0.0), p), Segment(100, DriveInput(100.0, -1, 5.0), p)]
    bad = y0.copy()
    bad[3] = np.inf
    with pytest.raises(ReferenceFailure) as info:
        solve(bad, segs, 50e-6, np.array([50, 150]))
    exc = info.value
    assert exc.segment == 0 and exc.segments == 2 and exc.time == 0.0
    assert 'non-finite' in str(exc) and 'segment 1 of 2' in str(exc)
    with pytest.raises(ValueError):
        solve(y0, segs, 50e-6, np.array([50]), method='rk45')


def _deltas(p: TableParams, y: np.ndarray) -> np.ndarray:
    """δ1, δ3 (m) of states y (n, 6), angle mesh phase: δ = r·θ − r2·θ2 − Σε_n sin(n·zθ + ϕ_n)."""
    out = np.empty((len(y), 2))
    for col, (theta, r, z) in enumerate(((0, p.radius_pinion_1, p.teeth_pinion_1),
                                         (2, p.radius_pinion_3, p.teeth_pinion_3))):
        eps = sum(a * np.sin((n + 1) * z * y[:, theta] + ph)
                  for n, (a, ph) in enumerate(zip(p.ste_amplitudes, p.ste_phases, strict=False)))
        out[:, col] = r * y[:, theta] - p.radius_table * y[:, 1] - eps
    return out


def _plant_run(p: TableParams, dt: float, torque: float, reversal: int, end: int,
               stride: int) -> tuple[np.ndarray, np.ndarray]:
    """RK4 as the node runs it (a session ticking ``stride`` steps): forward drive,
    reversal at step ``reversal``; (initial state, samples)."""
    y0, out, _ = reversal_run(p, SimSettings(dt=dt, publish_rate=1.0 / (stride * dt)), torque,
                              reversal, end)
    return y0, out


def test_rk4_at_default_step_against_reference_on_the_papers_case():
    """Default TableParams, 400 N·m at the paper's speed, a reversal at 0.3 s, 0.6 s in all."""
    p = TableParams(table_damping=PAPER_TABLE_DAMPING)
    dt, torque = 50e-6, 400.0
    reversal, end, stride = 6000, 12000, 20
    y0, rk4 = _plant_run(p, dt, torque, reversal, end, stride)
    samples = np.arange(stride, end + 1, stride)
    ref = solve(y0, [Segment(0, DriveInput(torque, 1, 0.0), p),
                     Segment(reversal, DriveInput(torque, -1, 0.0), p)], dt, samples)
    assert np.max(ref[:, 4]) > 0.33 and np.min(ref[:, 4]) < -0.33   # the paper's speed, both ways
    err = np.max(np.abs(rk4 - ref), axis=0)
    err_delta = np.max(np.abs(_deltas(p, rk4) - _deltas(p, ref)), axis=0)
    print('RK4 (50 µs) vs DOP853, max |error| θ1 θ2 θ3 [rad]:', err[:3],
          'ω1 ω2 ω3 [rad/s]:', err[3:], 'δ1 δ3 [m]:', err_delta)
    assert max(err[0], err[2]) < BOUND_ANGLE_PINION
    assert err[1] < BOUND_ANGLE_TABLE
    assert max(err[3], err[5]) < BOUND_SPEED_PINION
    assert err[4] < BOUND_SPEED_TABLE
    assert np.all(err_delta < BOUND_DELTA)
    # Richardson: the 100 µs run gives the 50 µs error as (y_100 − y_50)/15 without the
    # reference; it must agree with the reference's verdict (measured: within 1 %;
    # asserted: within 25 %).
    _, rk4_coarse = _plant_run(p, 2 * dt, torque, reversal // 2, end // 2, stride // 2)
    estimate = np.max(np.abs(rk4_coarse - rk4) / 15.0, axis=0)
    print('Richardson estimate of the same errors:', estimate)
    assert np.all((estimate > 0.8 * err) & (estimate < 1.25 * err))


def test_reference_and_check_follow_the_recorded_mesh_formulation(tmp_path):
    """The reference integrates the rhs of the parameters it is given, formulation
    included: for an `energy_consistent` run it agrees with RK4 to the paper case's
    bounds, while the `paper` equations from the same start are far off; check_run,
    reading the formulation from the bag, passes the recording, and fails it when the
    bag's parameters claim the other formulation."""
    from dataclasses import replace

    from bag_runs import record_session

    from screwgear_ros.bag.reader import read_run
    from screwgear_ros.runs.check import check_run
    from screwgear_ros.sim.schedule import Schedule

    p = TableParams(mesh_formulation='energy_consistent', table_damping=PAPER_TABLE_DAMPING)
    dt, torque = 50e-6, 400.0
    reversal, end, stride = 3000, 6000, 20
    y0, rk4 = _plant_run(p, dt, torque, reversal, end, stride)
    samples = np.arange(stride, end + 1, stride)

    def reference(params: TableParams) -> np.ndarray:
        return solve(y0, [Segment(0, DriveInput(torque, 1, 0.0), params),
                          Segment(reversal, DriveInput(torque, -1, 0.0), params)], dt, samples)

    ref = reference(p)
    err = np.max(np.abs(rk4 - ref), axis=0)
    assert max(err[0], err[2]) < BOUND_ANGLE_PINION and err[1] < BOUND_ANGLE_TABLE
    assert max(err[3], err[5]) < BOUND_SPEED_PINION and err[4] < BOUND_SPEED_TABLE
    other = np.max(np.abs(reference(p.replace(mesh_formulation='paper')) - ref), axis=0)
    assert np.all(other > 1e3 * err)

    settings = SimSettings(dt=dt, publish_rate=200.0, command_timeout=0.0)
    schedule = Schedule(p, settings, [Command('cmd_torque', torque, 0),
                                      Command('cmd_direction', -1, 4000)], end_step=8000)
    record_session(tmp_path / 'run', schedule)
    run = read_run(tmp_path / 'run')
    assert run.parameters.params.mesh_formulation == 'energy_consistent'
    report = check_run(run)
    assert report.ok and report.replay_identical
    claimed = replace(run, parameters=replace(run.parameters, params=p.replace(
        mesh_formulation='paper')))
    assert not check_run(claimed).ok
