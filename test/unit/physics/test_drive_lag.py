"""The drives' current loops (``drive_time_constant``) and cogging, against independent
answers: the step response of a first-order lag in closed form, the instant drive as
τ_d → 0, the DOP853 reference on a recorded run (check_run), and the ripple's frequency
counted in the published effort against the measured pinion speed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from bag_runs import installed_check_run, record_session

from screwgear_ros.bag.reader import read_run
from screwgear_ros.params.table import ParameterError, SimSettings, TableParams
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.plant import DriveInput, Plant
from screwgear_ros.sim.schedule import Schedule

PRELOAD = TableParams().preload_torque


def rk4_factor(z: float) -> float:
    """RK4's amplification of y' = λ·y over one step, z = λ·dt (its Taylor polynomial)."""
    return 1.0 + z + z * z / 2.0 + z ** 3 / 6.0 + z ** 4 / 24.0


def efforts(params: TableParams, dt: float, inputs: list[tuple[DriveInput, int]],
            stride: int) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and published efforts (n, 3: pinion 1, table, pinion 3) every ``stride``
    steps, each input held for its count of steps; plain RK4 (no located changes), so a
    step is one RK4 step."""
    plant = Plant(params, dt, contact_location=False)
    times, rows = [], []
    for drive, steps in inputs:
        plant.set_input(drive)
        for _ in range(steps // stride):
            out = plant.advance_outputs(stride)
            times.append(out.time)
            rows.append(out.effort)
    return np.array(times), np.array(rows)


@pytest.mark.parametrize('direction', [1, -1])
def test_the_applied_torque_steps_up_as_a_first_order_lag(direction: int) -> None:
    """A command T from rest: the active pinion's effort is ±(T_p + T·(1 − e^(−t/τ))), the
    other keeps its preload alone; within RK4's error on the lag, which is
    T·|R(−dt/τ)^n − e^(−t/τ)| (R: RK4's amplification), plus rounding. The ideal torque
    source (ω_nl = 0) keeps the speed out of it; the body moves freely."""
    tau, dt, torque = 2e-3, 50e-6, 300.0
    params = TableParams(drive_time_constant=tau, drive_no_load_speed=0.0)
    t, eff = efforts(params, dt, [(DriveInput(torque, direction, 0.0), 400)], 4)
    n = np.rint(t / dt)
    exact = torque * (1.0 - np.exp(-t / tau))
    rk4_error = torque * np.abs(rk4_factor(-dt / tau) ** n - np.exp(-t / tau))
    active, idle = (eff[:, 0] - PRELOAD, eff[:, 2] + PRELOAD) if direction > 0 else \
        (-(eff[:, 2] + PRELOAD), eff[:, 0] - PRELOAD)
    assert np.all(np.abs(active - exact) <= rk4_error * 1.000001 + 1e-10)
    assert np.max(rk4_error) > 1e-9          # the bound is RK4's, not rounding's
    assert np.all(idle == 0.0)
    assert exact[0] < 0.2 * torque and exact[-1] > 0.99 * torque


def test_a_reversal_hands_the_torque_over_through_both_lags() -> None:
    """After a reversal the old path's torque decays as T·e^(−t/τ) while the new one's
    rises as T·(1 − e^(−t/τ)) (each drive has its own current loop)."""
    tau, dt, torque = 1e-3, 25e-6, 200.0
    params = TableParams(drive_time_constant=tau, drive_no_load_speed=0.0)
    settle = 800                                 # 20 τ: the forward torque is all there
    t, eff = efforts(params, dt, [(DriveInput(torque, 1, 0.0), settle),
                                  (DriveInput(torque, -1, 0.0), 400)], 5)
    after = t > settle * dt
    s = t[after] - settle * dt
    decay = torque * np.exp(-s / tau)
    tol = torque * 1e-6
    assert np.all(np.abs(eff[after, 0] - PRELOAD - decay) <= tol)
    assert np.all(np.abs(-(eff[after, 2] + PRELOAD) - (torque - decay)) <= tol)


def test_the_lag_converges_to_the_instant_drive_as_tau_goes_to_zero() -> None:
    """The lag delays the torque by about τ: the state after a 0.1 s run approaches that
    of τ_d = 0 in proportion to τ."""
    dt = 10e-6
    inputs = [(DriveInput(400.0, 1, 0.0), 5000), (DriveInput(150.0, -1, 20.0), 5000)]

    def final(tau: float) -> np.ndarray:
        plant = Plant(TableParams(drive_time_constant=tau), dt)
        for drive, steps in inputs:
            plant.set_input(drive)
            plant.advance(steps)
        return plant.state.copy()

    instant = final(0.0)
    gaps = [float(np.max(np.abs(final(tau) - instant) / (np.abs(instant) + 1.0)))
            for tau in (4e-4, 1e-4, 2.5e-5)]
    print('relative gap to the instant drive at τ = 400, 100, 25 µs:', gaps)
    assert gaps[0] > gaps[1] > gaps[2] > 0.0
    assert 2.5 < gaps[0] / gaps[1] < 6.0 and 2.5 < gaps[1] / gaps[2] < 6.0


def test_a_time_constant_rk4_cannot_follow_is_refused() -> None:
    """The lag's eigenvalue −1/τ joins RK4's stability check: dt above 2.78·τ is refused."""
    with pytest.raises(ParameterError, match='dt'):
        Plant(TableParams(drive_time_constant=10e-6), 50e-6)
    Plant(TableParams(drive_time_constant=20e-6), 50e-6)


def test_cogging_ripples_at_its_order_times_the_pinion_speed() -> None:
    """With a cogging ripple of order n, pinion 1's effort oscillates n times per pinion
    revolution: its zero crossings about the mean, counted over a stretch at nearly
    constant speed, give n·ω̄1/(2π) (ω̄1 the mean published speed)."""
    dt, order = 50e-6, 40
    # No transmission error or stiffness fluctuation: they would swing the pinion's speed.
    params = TableParams(cogging_amplitude=5.0, cogging_order=order, table_damping=3000.0,
                         drive_no_load_speed=0.0, ste_amplitudes=(0.0,),
                         mesh_stiffness_amplitude=0.0)
    plant = Plant(params, dt)
    plant.set_input(DriveInput(400.0, 1, 0.0))
    plant.advance(int(0.3 / dt))                  # past the start (I2/c_t ≈ 15 ms)
    effort, speed = [], []
    for _ in range(int(0.5 / (2 * dt))):
        out = plant.advance_outputs(2)
        effort.append(out.effort[0])
        speed.append(out.velocity[0])
    effort, speed = np.array(effort), np.array(speed)
    ripple = effort - effort.mean()
    crossings = np.nonzero(np.signbit(ripple[1:]) != np.signbit(ripple[:-1]))[0]
    seconds = (crossings[-1] - crossings[0]) * 2 * dt
    measured = (len(crossings) - 1) / 2.0 / seconds
    expected = order * speed.mean() / (2.0 * math.pi)
    print(f'ripple {measured:.4f} Hz, n·ω̄1/2π {expected:.4f} Hz, '
          f'speed spread {np.ptp(speed) / speed.mean():.2e}')
    assert expected > 20.0 and np.ptp(speed) < 0.02 * speed.mean()
    assert abs(measured / expected - 1.0) < 5e-3
    assert np.ptp(ripple) > 9.0                   # the ripple is there: 2·T_cog


@pytest.mark.ros
def test_a_recorded_run_with_a_lag_checks_against_the_reference(tmp_path) -> None:
    """A run recorded as the node records it, with a 1 ms current loop and cogging,
    through a reversal: check_run's DOP853 reference integrates the same lagged drive
    torques and passes it, the published effort included (which lags the command)."""
    dt, tau = 50e-6, 1e-3
    params = TableParams(drive_time_constant=tau, cogging_amplitude=2.0, cogging_order=6,
                         table_damping=3000.0)
    settings = SimSettings(dt=dt, publish_rate=1000.0, command_timeout=0.0)
    at = lambda seconds: round(seconds / dt)
    schedule = Schedule(params, settings, [
        Command('cmd_torque', 300.0, at(0.1)), Command('cmd_direction', -1, at(0.4)),
        Command('cmd_torque', 0.0, at(0.7))], end_step=at(0.9))
    record_session(tmp_path / 'lag', schedule)
    run = read_run(tmp_path / 'lag')
    effort_1 = run.joint_states.values[:, 6]
    steps = run.joint_states.steps
    first = int(np.searchsorted(steps, at(0.1) + at(1e-3)))   # 1 ms (one τ) after the command
    assert effort_1[first] < PRELOAD + 0.8 * 300.0             # not there yet: it lags
    result = installed_check_run(tmp_path / 'lag')
    print(result.stdout)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'RESULT: PASS' in result.stdout
