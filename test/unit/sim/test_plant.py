"""Plant: time keeping, reset, the non-finite fault path, outputs, determinism."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from screwgear_ros.numerics.stability import max_stable_dt
from screwgear_ros.params.table import ParameterError, SimSettings, TableParams
from screwgear_ros.physics.equilibrium import EquilibriumNotFound, equilibrium_state
from screwgear_ros.sim.plant import DriveInput, Plant
from screwgear_ros.sim.session import Session

DT = 50e-6


def test_time_is_step_times_dt_and_reset_keeps_it():
    plant = Plant(TableParams(table_damping=8867.0), DT)
    rest = plant.state.copy()
    plant.set_input(DriveInput(300.0, 1, 0.0))
    for _ in range(7):
        assert plant.advance(1000)
    assert plant.step == 7000 and plant.time == 7000 * DT
    assert plant.state[1] > 0.01                        # the table has turned
    plant.reset()
    assert plant.step == 7000 and plant.time == 7000 * DT
    assert np.array_equal(plant.state, rest)
    assert plant.input == DriveInput(300.0, 1, 0.0)     # reset is about the state only
    out = plant.compute_outputs()
    assert out.time == 7000 * DT and out.step == 7000


def test_unstable_step_refused_at_construction_and_on_parameter_change():
    p = TableParams()
    with pytest.raises(ParameterError) as exc:
        Plant(p, 1.1 * max_stable_dt(p))
    assert exc.value.name == 'dt'
    plant = Plant(p, 1e-3)                              # fine at k_m = 1e7 (limit ~1.95 ms)
    with pytest.raises(ParameterError):
        plant.set_params(p.replace(mesh_stiffness_mean=1e8))   # limit drops to ~0.6 ms
    assert plant.params == p
    with pytest.raises(ValueError):
        plant.set_params(p.replace(mode='conventional'))
    plant.set_params(p.replace(backlash=1e-5))
    assert plant.params.backlash == 1e-5


def test_non_finite_state_stops_at_the_last_finite_state():
    """RK4 past its stability limit blows up: the plant keeps the last finite state and says so.

    Plant() and set_params refuse such a step, so the step is raised behind the plant's
    back to exercise the guard the node relies on.
    """
    p = TableParams()
    plant = Plant(p, DT)
    plant.set_input(DriveInput(200.0, 1, 0.0))
    assert plant.advance(400)
    good_state, good_step = plant.state.copy(), plant.step
    plant.dt = 3.0 * max_stable_dt(p)    # the bound is conservative: go well past it
    assert not plant.advance(5000)
    assert plant.fault is not None and 'non-finite' in plant.fault
    assert np.array_equal(plant.state, good_state)
    assert plant.step == good_step
    out = plant.compute_outputs()
    assert all(math.isfinite(v) for v in (*out.position, *out.velocity, *out.effort,
                                          *out.delta, *out.delta_rate, *out.mesh_force))
    assert not plant.advance(1)                         # stays stopped
    assert np.array_equal(plant.state, good_state)
    plant.dt = DT
    plant.reset()                                       # reset clears the fault
    assert plant.fault is None and plant.advance(10)


@pytest.mark.parametrize('mode', ['anti_backlash', 'conventional'])
def test_outputs_are_consistent_with_the_model(mode):
    p = TableParams(mode=mode, table_damping=50.0, ste_phases=(0.3,))
    plant = Plant(p, DT)
    plant.set_input(DriveInput(150.0, -1, 12.0))
    plant.advance(299)
    speed_before = plant.state[4]
    plant.advance(1)
    out = plant.compute_outputs()
    th1, th2, th3 = out.position
    eps1 = 1.5384e-3 * math.sin(24 * th1 + 0.3)
    eps3 = 1.5384e-3 * math.sin(24 * th3 + 0.3)
    assert out.delta[0] == pytest.approx(0.078 * th1 - 0.582 * th2 - eps1, abs=1e-15)
    assert out.delta[1] == pytest.approx(0.078 * th3 - 0.582 * th2 - eps3, abs=1e-15)
    if mode == 'anti_backlash':
        assert out.effort[0] == 350.0 and out.effort[2] == -350.0 - 150.0
        assert out.active_path == 3 and out.transmission_error == out.delta[1]
    else:
        assert out.effort[0] == -150.0 and out.effort[2] == 0.0
        assert out.mesh_force[1] == 0.0
        assert out.active_path == 1 and out.transmission_error == out.delta[0]
    table = 0.582 * sum(out.mesh_force) - 12.0 - 50.0 * out.velocity[1]
    assert out.effort[1] == pytest.approx(table, rel=1e-12)
    # the table's effort is its inertia times its acceleration (Newton, §3): check against
    # a central difference of the integrated speed over ±1 step, whose error is about
    # (ω·dt)²/6 ≈ 8e-4 of the mesh-mode part (ω ≈ 1.4e3 rad/s)
    plant.advance(1)
    accel = (plant.state[4] - speed_before) / (2 * DT)
    assert out.effort[1] == pytest.approx(p.inertia_table * accel, rel=2e-3)


def test_an_equilibrium_newton_cannot_find_is_an_error_saying_so():
    """An STE slope z·ε = 0.072 m/rad close to r1 = 0.078 m and a soft mesh whose
    stiffness varies by a factor 7 over a tooth, under a 1500 N·m preload: the preload
    equation is not monotonic in the pinion angle and Newton's method runs away. The
    plant is refused with a typed error instead of starting from where Newton stopped."""
    p = TableParams(ste_amplitudes=(3.0e-3,), mesh_stiffness_mean=2e6,
                    mesh_stiffness_amplitude=1.5e6, preload_torque=1500.0)
    with pytest.raises(EquilibriumNotFound) as exc:
        Plant(p, DT)
    assert 'forward flank' in exc.value.what and exc.value.iterations == 100
    assert abs(exc.value.residual) > 1.0                     # m: nowhere near a solution
    assert 'did not converge in 100 Newton iterations' in str(exc.value)
    with pytest.raises(EquilibriumNotFound):
        equilibrium_state(p)


def test_the_session_hands_contact_location_to_the_plant():
    for locate in (True, False):
        session = Session(TableParams(), SimSettings(contact_location=locate))
        assert session.plant.contact_location is locate
    assert Plant(TableParams(), DT).contact_location is True


def test_two_plants_fed_the_same_inputs_agree_bit_for_bit():
    p = TableParams(table_damping=8867.0)
    schedule = {0: DriveInput(400.0, 1, 0.0), 2000: DriveInput(400.0, -1, 0.0),
                3100: DriveInput(50.0, -1, 30.0), 4000: DriveInput(0.0, 1, 0.0)}

    def run(chunk: int) -> list:
        plant = Plant(p, DT)
        outs = []
        while plant.step < 5000:
            if plant.step in schedule:
                plant.set_input(schedule[plant.step])
            plant.advance(chunk)
            outs.append(plant.compute_outputs())
        return outs

    a, b = run(20), run(20)
    assert a == b
    assert np.array_equal(equilibrium_state(p), Plant(p, DT).state)


def test_one_call_ticks_equal_advance_then_outputs_and_the_model_itself():
    """advance_outputs (integrate, check, observe in one compiled call) gives exactly what
    advance() then compute_outputs() give, and compute_outputs() is
    model.effort_and_meshes of the state, also across input changes, conventional mode
    and the fault path."""
    from screwgear_ros.physics.motion import effort_and_meshes as model_outputs
    for mode in ('anti_backlash', 'conventional'):
        p = TableParams(mode=mode, table_damping=8867.0)
        fused, split = Plant(p, DT), Plant(p, DT)
        for drive in [DriveInput(400.0, 1, 0.0), DriveInput(400.0, -1, 20.0),
                      DriveInput(0.0, 1, 0.0)]:
            fused.set_input(drive)
            split.set_input(drive)
            for _ in range(40):
                a = fused.advance_outputs(20)
                assert split.advance(20)
                b = split.compute_outputs()
                assert a == b
            m = fused._model
            expected = model_outputs(fused.time, tuple(float(v) for v in fused.full_state), m,
                                     drive.kernel)
            assert (*a.effort, a.delta[0], a.delta_rate[0], a.mesh_force[0], a.delta[1],
                    a.delta_rate[1], a.mesh_force[1]) == tuple(expected)
            assert a.position == tuple(fused.state[:3]) and a.velocity == tuple(fused.state[3:])
    good = fused.state.copy()
    fused.dt = 3.0 * max_stable_dt(p)                   # blow up behind the plant's back
    out = fused.advance_outputs(5000)
    assert fused.fault is not None and np.array_equal(fused.state, good)
    assert out.step == fused.step and out.position == tuple(good[:3])


def test_the_fast_drive_input_is_what_the_dataclass_makes():
    """DriveInput.of (the session folds a command into one every tick) makes exactly what
    the frozen dataclass's own constructor makes: every field, equality, hash, repr,
    and it stays frozen."""
    for values in [(0.0, 1, 0.0), (123.5, -1, -7.25), (1e-300, 1, 3e5)]:
        fast, made = DriveInput.of(*values), DriveInput(*values)
        assert vars(fast) == vars(made)
        assert fast == made and hash(fast) == hash(made) and repr(fast) == repr(made)
        with pytest.raises(dataclasses.FrozenInstanceError):
            fast.torque = 1.0          # type: ignore[misc]


@pytest.mark.parametrize('mode', ['anti_backlash', 'conventional'])
def test_set_drive_is_set_input_of_the_same_input(mode):
    """set_drive(torque, direction) (a closed loop's answer, every tick) leaves the plant
    as set_input(DriveInput(torque, direction, load in force)) does: the input read back,
    its direction and path, and the bits of the steps after; direction 0 keeps the one
    in force."""
    params = TableParams(mode=mode, table_damping=8867.0)
    fast, made = Plant(params, DT), Plant(params, DT)
    for plant in (fast, made):
        plant.set_input(DriveInput(0.0, 1, 25.0))
    for torque, direction in [(150.0, 1), (80.5, -1), (0.0, 0), (300.0, 0), (12.0, 1)]:
        kept = made.input.direction if direction == 0 else direction
        fast.set_drive(torque, direction)
        made.set_input(DriveInput(torque, kept, made.input.load))
        assert fast.input == made.input and type(fast.input.direction) is int
        assert (fast.direction, fast.active_path) == (kept, made.compute_outputs().active_path)
        fast.advance_outputs(40)
        made.advance_outputs(40)
        assert fast.full_state.tobytes() == made.full_state.tobytes()
        assert fast.observed.tobytes() == made.observed.tobytes()


def test_a_state_array_put_in_the_plant_is_the_one_integrated():
    """Assigning ``plant.state`` after the plant has run (its compiled call is then
    chosen) integrates from the assigned values (copied into a new state array), exactly
    as a plant that always had them."""
    p = TableParams(table_damping=8867.0)
    a, b = Plant(p, DT), Plant(p, DT)
    for plant in (a, b):
        plant.set_input(DriveInput(300.0, 1, 0.0))
        plant.advance(40)
    moved = a.state.copy()
    a.state = moved
    a.advance(40)
    b.advance(40)
    assert np.array_equal(a.state, b.state) and not np.array_equal(moved, a.state)
    assert a.compute_outputs() == b.compute_outputs()


def test_a_plant_that_ran_copies_and_pickles_and_the_copy_runs_on_bit_for_bit():
    import copy
    import pickle
    plant = Plant(TableParams(table_damping=8867.0), DT)
    plant.set_input(DriveInput(250.0, -1, 10.0))
    plant.advance(40)
    twins = [pickle.loads(pickle.dumps(plant)), copy.deepcopy(plant)]
    expected = plant.advance_outputs(40)
    for twin in twins:
        assert twin.advance_outputs(40) == expected
        assert np.array_equal(twin.state, plant.state)
