"""Bearing friction with exact sticking (screwgear_ros.physics.friction, docs/model_notes.md §14).

The law's pieces are checked against the law written out here from its definition
(Modelica's BearingFriction with an exponential Stribeck curve), the parameters against
their rules; the integrated model against closed forms (breakaway at the static torque
referred through the gear ratio, coasting to a stop in I·ω0/τ_C), against itself at
halved steps (RK4's order through stick-slip) and against the DOP853 reference with its
own friction events (check_run on a recorded run).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from bag_runs import installed_check_run

from screwgear_ros import Simulation
from screwgear_ros.bag.reader import read_run
from screwgear_ros.numerics.integrator import OBSERVED
from screwgear_ros.params.table import ParameterError, SimSettings, TableParams
from screwgear_ros.physics.friction import (
    FrictionPiece,
    at_rest,
    friction_on,
    friction_piece,
    sliding_torque,
)
from screwgear_ros.physics.motion import BY_LAW, Pieces, pieces, rate_and_friction, state_rate
from screwgear_ros.physics.packed import Drive, pack
from screwgear_ros.runs.check import check_run, format_report
from screwgear_ros.runs.session_record import record_session
from screwgear_ros.sim.control import DemoController, DemoGains
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.plant import Plant
from screwgear_ros.sim.schedule import Schedule

COULOMB, STATIC, STRIBECK = 3.0, 5.0, 0.02      # N·m, N·m, rad/s


def _friction(speed: float, coulomb: float, static: float, stribeck: float) -> float:
    """T_f(ω) in slip from the definition: −sign(ω)·(τ_C + (τ_S − τ_C)·exp(−|ω|/ω_S))."""
    decay = math.exp(-abs(speed) / stribeck) if stribeck > 0.0 else 0.0
    return -math.copysign(coulomb + (static - coulomb) * decay, speed)


@pytest.mark.parametrize('stribeck', [STRIBECK, 0.0])
def test_sliding_torque_is_the_stribeck_curve(stribeck):
    rng = np.random.default_rng(23)
    for speed in rng.uniform(-1.0, 1.0, 200):
        piece = FrictionPiece.SLIP_FORWARD if speed > 0 else FrictionPiece.SLIP_BACKWARD
        assert sliding_torque(piece, speed, COULOMB, STATIC, stribeck) == pytest.approx(
            _friction(speed, COULOMB, STATIC, stribeck), rel=1e-14)
    # leaving rest, the sliding torque starts at the breakaway torque (with a Stribeck
    # curve) and falls to the Coulomb torque far from rest
    if stribeck > 0.0:
        assert sliding_torque(FrictionPiece.SLIP_FORWARD, 0.0, COULOMB, STATIC,
                              stribeck) == -STATIC
        assert sliding_torque(FrictionPiece.SLIP_BACKWARD, 0.0, COULOMB, STATIC,
                              stribeck) == STATIC
    assert sliding_torque(FrictionPiece.SLIP_FORWARD, 100.0, COULOMB, STATIC,
                          stribeck) == pytest.approx(-COULOMB, rel=1e-15)
    # a slip piece is continued smoothly past zero (the stage the integrator locates)
    assert sliding_torque(FrictionPiece.SLIP_FORWARD, -1e-6, COULOMB, STATIC, stribeck) < 0.0
    assert sliding_torque(FrictionPiece.STUCK, 0.0, COULOMB, STATIC, stribeck) == 0.0


def test_pieces():
    F, S, B = FrictionPiece.SLIP_FORWARD, FrictionPiece.STUCK, FrictionPiece.SLIP_BACKWARD
    # at rest: stuck while the holding torque is within ±τ_S (the bounds included)
    for torque, piece in ((0.0, S), (STATIC, S), (-STATIC, S), (STATIC * (1 + 1e-15), F),
                          (-STATIC * (1 + 1e-15), B)):
        assert at_rest(torque, STATIC) == piece
        assert friction_piece(FrictionPiece.FROM_STATE, 0.0, torque, STATIC) == piece
        assert friction_piece(S, 0.0, torque, STATIC) == piece
    # slipping: stays on its piece while the speed keeps its sign, whatever the torque
    assert friction_piece(F, 1e-9, -100.0, STATIC) == F
    assert friction_piece(B, -1e-9, 100.0, STATIC) == B
    assert friction_piece(FrictionPiece.FROM_STATE, 1e-9, -100.0, STATIC) == F
    assert friction_piece(FrictionPiece.FROM_STATE, -1e-9, 100.0, STATIC) == B
    # the speed reaching or crossing zero: sticks, or slips on in the sense of the torque
    for held, speed, reversed_ in ((F, 0.0, B), (F, -1e-12, B), (B, 0.0, F), (B, 1e-12, F)):
        assert friction_piece(held, speed, 0.5 * STATIC, STATIC) == S
        pushed = 2.0 * STATIC if reversed_ == F else -2.0 * STATIC
        assert friction_piece(held, speed, pushed, STATIC) == reversed_
    # a speed that reached zero under a torque beyond τ_S in its old sense: breaks away
    # from rest; one that crossed zero is a change all the same (its crossing is an event
    # to locate), so it is judged stuck and breaks away from rest where it is located
    assert friction_piece(F, 0.0, 2.0 * STATIC, STATIC) == F
    assert friction_piece(B, 0.0, -2.0 * STATIC, STATIC) == B
    assert friction_piece(F, -1e-12, 2.0 * STATIC, STATIC) == S
    assert friction_piece(B, 1e-12, -2.0 * STATIC, STATIC) == S
    # no static torque: no friction, whatever else
    for held in FrictionPiece:
        assert friction_piece(held, 0.0, 0.0, 0.0) == FrictionPiece.NONE


def test_accelerations_on_each_piece():
    inertia = 0.7
    rng = np.random.default_rng(5)
    for torque, speed in zip(rng.normal(0.0, 10.0, 100), rng.normal(0.0, 0.1, 100), strict=True):
        # no friction: exactly τ/I, the expression of the model without friction
        assert friction_on(FrictionPiece.NONE, speed, torque, inertia, COULOMB, STATIC,
                           STRIBECK) == (torque / inertia, 0.0)
        # stuck: no acceleration at all, the bearing holds −τ
        assert friction_on(FrictionPiece.STUCK, 0.0, torque, inertia, COULOMB, STATIC,
                           STRIBECK) == (0.0, -torque)
        piece = FrictionPiece.SLIP_FORWARD if speed > 0 else FrictionPiece.SLIP_BACKWARD
        acceleration, friction = friction_on(piece, speed, torque, inertia, COULOMB, STATIC,
                                             STRIBECK)
        expected = _friction(speed, COULOMB, STATIC, STRIBECK)
        assert friction == pytest.approx(expected, rel=1e-14)
        assert acceleration == pytest.approx((torque + expected) / inertia, rel=1e-12,
                                             abs=1e-12)


def test_parameters():
    p = TableParams()
    # off by default: today's model
    for body in ('table', 'pinion'):
        assert getattr(p, f'{body}_coulomb_torque') == 0.0
        assert getattr(p, f'{body}_static_torque') == 0.0
        assert getattr(p, f'{body}_stribeck_speed') == 0.0
    assert p.pinion_damping == 0.0
    TableParams(table_coulomb_torque=3.0, table_static_torque=3.0)
    TableParams(pinion_static_torque=2.0)            # pure stiction
    for body in ('table', 'pinion'):
        with pytest.raises(ParameterError, match=f'{body}_static_torque.*>= {body}_coulomb'):
            TableParams(**{f'{body}_coulomb_torque': 3.0, f'{body}_static_torque': 2.0})
        with pytest.raises(ParameterError, match=f'{body}_stribeck_speed'):
            TableParams(**{f'{body}_stribeck_speed': -1.0})
    with pytest.raises(ParameterError, match='pinion_damping'):
        TableParams(pinion_damping=-1.0)


# ------------------------------------------------------------------ integrated: closed forms

def _steps(plant: Plant, n: int) -> np.ndarray:
    """The plant's observed vector after each of its next n steps (n × OBSERVED)."""
    rows = np.empty((n, OBSERVED))
    assert plant.advance_ticks(n, 1, rows) == n and plant.fault is None
    return rows


#: Breakaway: the table's bearing (τ_C2 < τ_S2, Stribeck), no pinion friction, the ideal
#: torque source ramped smoothly by the drive's fluctuation T_v·sin(ω_v·t) (zero command),
#: so that the torque reaching the table grows quasi-statically (1e-3 N·m a step).
RAMP_TOP, RAMP_TIME = 40.0, 2.0            # N·m at the pinion, s to reach it
TABLE_STATIC = 200.0                       # N·m


def _breakaway_params(mode: str) -> TableParams:
    return TableParams(mode=mode, table_coulomb_torque=150.0, table_static_torque=TABLE_STATIC,
                       table_stribeck_speed=0.01, drive_no_load_speed=0.0,
                       ste_amplitudes=(20e-6,), ste_phases=(0.0,),
                       torque_fluctuation_amplitude=RAMP_TOP,
                       torque_fluctuation_frequency=math.pi / (2.0 * RAMP_TIME))


@pytest.mark.parametrize('mode', ['anti_backlash', 'conventional'])
def test_breakaway_under_a_slow_torque_ramp(mode):
    """The table stands exactly still (the pinion winds up the mesh by its elastic
    deflection) until the torque reaching it, r2/r1 times the drive torque (the preloads
    cancel: r1 = r3), exceeds τ_S2; it breaks away there, within 0.5 %."""
    p = _breakaway_params(mode)
    dt = 50e-6
    plant = Plant(p, dt)
    y0 = plant.state.copy()
    rows = _steps(plant, round(RAMP_TIME / dt))
    moved = np.flatnonzero(rows[:, 1] != y0[1])
    assert moved.size, 'the table never broke away'
    first = moved[0]                        # the first step that ends with the table moved
    t_lo, t_hi = first * dt, (first + 1) * dt
    ramp = RAMP_TOP * np.sin(p.torque_fluctuation_frequency * np.array([t_lo, t_hi]))
    predicted = TABLE_STATIC * p.radius_pinion_1 / p.radius_table
    print(f'{mode}: table breaks away at t = {t_hi:.5f} s, drive torque {ramp[1]:.5f} N·m, '
          f'predicted {predicted:.5f} N·m ({ramp[1] / predicted - 1:+.2e})')
    assert abs(ramp[0] / predicted - 1.0) < 0.005 and abs(ramp[1] / predicted - 1.0) < 0.005
    # before: not the slightest table motion, the pinion wound up by the elastic deflection
    before = rows[:first]
    assert np.all(before[:, 1] == y0[1]) and np.all(before[:, 4] == 0.0)
    windup = p.radius_pinion_1 * (before[-1, 0] - y0[0])
    k = p.mesh_stiffness_mean
    elastic = predicted / p.radius_pinion_1 / k                # F/K at the breakaway, m
    assert 0.5 * elastic < windup < 2.0 * elastic, (windup, elastic)
    # after: it slides forward and keeps sliding (the torque keeps growing)
    after = rows[first:]
    assert np.all(after[:, 4] > 0.0)


@pytest.mark.parametrize('body', ['table', 'pinion 3'])
def test_coasting_to_a_stop_under_coulomb_friction(body):
    """A body coasting from ω0 under Coulomb friction alone decelerates at τ_C/I, stops at
    I·ω0/τ_C (its angle then ω0²·I/(2·τ_C) on), and stays stopped: closed forms, which
    RK4 integrates exactly (the speed is linear in time) up to rounding, the stop
    located inside its step. The table coasts with pinion 1 in the middle of a wide
    backlash gap (conventional, b = 1 cm), pinion 3 is the disengaged one."""
    dt = 50e-6
    if body == 'table':
        p = TableParams(mode='conventional', backlash=1e-2, ste_amplitudes=(), ste_phases=(),
                        table_coulomb_torque=0.25, table_static_torque=0.25)
        index, omega0, inertia, coulomb = 1, 0.01, p.inertia_table, 0.25
        y0 = np.zeros(6)
    else:
        p = TableParams(mode='conventional', pinion_coulomb_torque=0.5,
                        pinion_static_torque=0.5)
        index, omega0, inertia, coulomb = 2, 2.1, p.inertia_pinion_3, 0.5
        y0 = Plant(p, dt).state.copy()
    y0[3 + index] = omega0
    stop = inertia * omega0 / coulomb
    plant = Plant(p, dt, initial_state=y0)
    rows = _steps(plant, round(1.5 * stop / dt))
    t = np.arange(1, len(rows) + 1) * dt
    speed, angle = rows[:, 3 + index], rows[:, index]
    stopped = np.flatnonzero(speed == 0.0)
    assert stopped.size
    k = stopped[0]
    sliding = t < stop - dt
    assert np.allclose(speed[sliding], omega0 - coulomb / inertia * t[sliding],
                       rtol=0.0, atol=1e-12 * omega0)
    assert t[k] - dt - 1e-12 < stop <= t[k] + 1e-12     # stopped inside step k
    travel = angle[k] - y0[index]
    measured_stop = 2.0 * travel / omega0
    print(f'{body}: stop at {measured_stop!r} s, I·ω0/τ_C = {stop!r} s '
          f'({measured_stop / stop - 1:+.1e})')
    assert measured_stop == pytest.approx(stop, rel=1e-10)
    assert np.all(speed[k:] == 0.0) and np.all(angle[k:] == angle[k])


# ------------------------------------------------------------------ convergence

#: Stick-slip: both bearings with a Stribeck curve, the drive torque swinging ±60 N·m at
#: 2 Hz on pinion 1 (zero command, the ideal source's fluctuation): the table (up to
#: 448 N·m reaching it, τ_S2 = 200 N·m) sticks and breaks away twice a period, the pinions
#: stick and slip on their own bearings against the preload.
STICK_SLIP = {'table_coulomb_torque': 150.0, 'table_static_torque': 200.0,
                  'table_stribeck_speed': 0.01, 'pinion_coulomb_torque': 1.0,
                  'pinion_static_torque': 1.5, 'pinion_stribeck_speed': 0.05, 'pinion_damping': 0.5,
                  'table_damping': 50.0, 'drive_no_load_speed': 0.0, 'ste_amplitudes': (20e-6,),
                  'ste_phases': (0.0,), 'torque_fluctuation_amplitude': 60.0,
                  'torque_fluctuation_frequency': 4.0 * math.pi}
STICK_SLIP_END, STICK_SLIP_SAMPLE = 1.0, 1e-3     # s


def _stick_slip_run(dt: float, locate: bool) -> tuple[np.ndarray, int]:
    """(states every STICK_SLIP_SAMPLE, changes located) of the stick-slip run."""
    plant = Plant(TableParams(**STICK_SLIP), dt, contact_location=locate)
    stride = round(STICK_SLIP_SAMPLE / dt)
    ticks = round(STICK_SLIP_END / STICK_SLIP_SAMPLE)
    rows = np.empty((ticks, OBSERVED))
    assert plant.advance_ticks(ticks, stride, rows) == ticks and plant.fault is None
    return rows[:, :6].copy(), plant.contact_changes


def _orders(runs: list[np.ndarray]) -> np.ndarray:
    """Per state component, the order by Richardson differences of runs at dt, dt/2, dt/4."""
    coarse = np.max(np.abs(runs[0] - runs[1]), axis=0)
    fine = np.max(np.abs(runs[1] - runs[2]), axis=0)
    return np.log2(coarse / fine)


def test_rk4_keeps_fourth_order_through_stick_slip():
    """Halving dt 200 → 100 → 50 µs: order ≥ 3.5 on every state component with the
    transitions located; with location off (the plain law: a body coming to rest
    chatters about zero) the order drops."""
    dts = (200e-6, 100e-6, 50e-6)
    located = [_stick_slip_run(dt, True) for dt in dts]
    fixed = [_stick_slip_run(dt, False)[0] for dt in dts]
    runs = [run for run, _ in located]
    table = runs[-1][:, 1]
    order, order_fixed = _orders(runs), _orders(fixed)
    stuck_samples = int(np.sum(runs[-1][:, 4] == 0.0))
    print(f'stick-slip: {[n for _, n in located]} changes located at {dts} s; table stuck '
          f'at {stuck_samples} of {len(table)} samples, travels {table[-1] - table[0]:.4g} rad')
    print(f'  order located θ1 θ2 θ3 ω1 ω2 ω3: {np.round(order, 2)}')
    print(f'  order fixed step:                {np.round(order_fixed, 2)}')
    changes = [n for _, n in located]
    assert stuck_samples > 20 and np.ptp(table) > 1e-3       # it does stick and slip
    assert changes[0] == changes[1] == changes[2] > 10      # the same events at every dt
    assert np.all(order >= 3.5)
    assert np.min(order_fixed) < 2.5


# ------------------------------------------------------------------ against the reference

@pytest.mark.ros
def test_a_recorded_run_with_friction_checks_against_the_reference(tmp_path):
    """A run recorded as the node records it, with stick-slip on every bearing (the drive
    torque swinging on the table, then a reversal and a stop under friction), passes
    check_run: the DOP853 reference with its own friction events agrees with RK4 within
    RK4's own error estimate."""
    dt = 50e-6
    params = TableParams(**{**STICK_SLIP, 'drive_no_load_speed': 8.0 * math.pi})
    settings = SimSettings(dt=dt, publish_rate=1000.0, command_timeout=0.0)
    at = lambda seconds: round(seconds / dt)
    schedule = Schedule(params, settings, [
        Command('cmd_torque', 30.0, at(0.2)), Command('cmd_direction', -1, at(0.6)),
        Command('cmd_torque', 0.0, at(1.0))], end_step=at(1.4))
    record_session(tmp_path / 'friction', schedule)
    run = read_run(tmp_path / 'friction')
    table_speed = run.joint_states.values[:, 4]
    stuck = int(np.sum(table_speed == 0.0))
    result = installed_check_run(tmp_path / 'friction')
    print(f'table stuck at {stuck} of {len(table_speed)} samples')
    print(result.stdout)
    assert stuck > 20
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'RESULT: PASS' in result.stdout


def test_a_sticking_episode_inside_one_reference_step_is_located(tmp_path):
    """A table held at a small target by the demo controller on catalogue bearings
    (τ_S 4 N·m, τ_C 3 N·m on the table; hundredths of a N·m on the pinions) sticks and
    slips at speeds of µrad/s; a pinion sticks for a fraction of a millisecond, shorter
    than the reference's step at its tolerance. Its speed then crosses zero inside the
    step and the torque has grown past τ_S in the old sense by the step's end: that
    crossing must still be located (the reference otherwise runs the slip law through
    the whole episode, and disagrees with itself at another tolerance and with RK4)."""
    dt = 50e-6
    params = TableParams(table_coulomb_torque=3.0, table_static_torque=4.0,
                         table_stribeck_speed=0.005, pinion_coulomb_torque=0.05,
                         pinion_static_torque=0.07, pinion_stribeck_speed=0.5)
    encoders = {}
    for joint, counts, noise in (('table', 2 ** 26, 3e-8), ('pinion_1', 2 ** 20, 2e-6),
                                 ('pinion_3', 2 ** 20, 2e-6)):
        encoders.update({f'encoder_counts_{joint}': counts, f'position_noise_{joint}': noise,
                         f'measurement_delay_{joint}': 1,
                         f'velocity_filter_cutoff_{joint}': 500.0})
    settings = SimSettings(dt=dt, sensor_seed=1, **encoders)
    controller = DemoController(DemoGains(targets=(0.001,), dwell=1e9), dt=dt)
    Simulation(params, settings).run(controller, 3.0, record=tmp_path / 'hold')
    run = read_run(tmp_path / 'hold')
    stuck = int(np.sum(run.true_velocity[:, 2] == 0.0))          # the exact state
    report = check_run(run, parallel=False)
    print(f'pinion 3 stuck at {stuck} of {len(run.true_joint_states)} samples')
    print(format_report(report))
    assert stuck > 20
    assert report.ok, format_report(report)


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_rate_and_friction_is_state_rate_and_pieces_from_one_evaluation(seed):
    """The reference's fused evaluation gives the bits of the two it replaces: the slope
    of ``state_rate`` and the friction pieces of ``pieces``, on random states near rest
    (where the pieces change) coming from every piece a step can hold."""
    rng = np.random.default_rng(seed)
    params = replace(TableParams(), table_coulomb_torque=3.0, table_static_torque=4.0,
                      table_stribeck_speed=0.005, pinion_coulomb_torque=0.05,
                      pinion_static_torque=0.07, pinion_stribeck_speed=0.5)
    model = pack(params)
    kinds = [FrictionPiece.SLIP_FORWARD, FrictionPiece.STUCK, FrictionPiece.SLIP_BACKWARD]
    for _ in range(200):
        y = tuple(float(v) for v in np.concatenate([rng.normal(0.0, 1e-4, 3),
                                                    rng.normal(0.0, 1e-3, 3),
                                                    rng.normal(0.0, 10.0, 2)]))
        held = Pieces(BY_LAW.branch_1, BY_LAW.branch_3, BY_LAW.drive,
                      *(kinds[int(k)] for k in rng.integers(0, 3, 3)))
        drive = Drive(float(rng.uniform(0.0, 400.0)), float(rng.choice([-1.0, 1.0])),
                      float(rng.normal(0.0, 50.0)))
        rate, friction = rate_and_friction(0.01, y, model, drive, held)
        law = pieces(0.01, y, model, drive, held)
        assert rate == state_rate(0.01, y, model, drive, held)[0], f'seed {seed}'
        assert friction == (law.friction_1, law.friction_2, law.friction_3), f'seed {seed}'
