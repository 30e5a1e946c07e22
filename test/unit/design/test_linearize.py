"""linearize: the linear model against closed forms of the symmetric 3-DOF system, against
a finite-difference Jacobian of the model's right-hand side, against the RK4 stability
check's own linearization, against a simulated steady state, and through python-control;
the executable writes named matrices and refuses bad input with exit 2."""

from __future__ import annotations

import math
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest
from bag_runs import installed

from screwgear_ros.design.errors import (
    MeshModelUnsupported,
    NoSteadyState,
    OperatingPointRefused,
)
from screwgear_ros.design.linear_model import INPUTS, OUTPUTS, STATES
from screwgear_ros.design.linearize import linearize
from screwgear_ros.design.operating_point import operating_point
from screwgear_ros.errors import ScrewgearError
from screwgear_ros.inprocess.simulation import Simulation
from screwgear_ros.params.table import MeshPhase, Mode, TableParams
from screwgear_ros.physics.drive import DrivePiece
from screwgear_ros.physics.mesh import ContactBranch
from screwgear_ros.physics.motion import rhs, stiffest_linearization
from screwgear_ros.physics.packed import Drive, pack

PAPER = TableParams()


def _symmetric(rng: np.random.Generator) -> tuple[TableParams, float]:
    """An undamped symmetric table (I1 = I3, r1 = r3) with thermal derating, preload
    stiffness, stiffness fluctuation and STE, and its mean mesh stiffness k, computed here."""
    i1 = rng.uniform(0.01, 0.1)
    r1 = rng.uniform(0.05, 0.1)
    k_m, alpha, rise, k_p = rng.uniform(5e6, 5e7), 1e-3, rng.uniform(0.0, 50.0), \
        rng.uniform(0.0, 2e6)
    params = PAPER.replace(inertia_pinion_1=i1, inertia_pinion_3=i1, radius_pinion_1=r1,
                           radius_pinion_3=r1, inertia_table=rng.uniform(10.0, 80.0),
                           radius_table=rng.uniform(0.3, 0.8), mesh_stiffness_mean=k_m,
                           thermal_coefficient=alpha, temperature_rise=rise,
                           preload_stiffness=k_p, mesh_damping=0.0, table_damping=0.0,
                           mesh_stiffness_amplitude=0.05 * k_m)
    return params, k_m * (1.0 - alpha * rise) + k_p


@pytest.mark.parametrize('seed', range(4))
def test_eigenfrequencies_at_the_preload_equilibrium_are_the_closed_forms(seed):
    params, k = _symmetric(np.random.default_rng(seed))
    i1, i2 = params.inertia_pinion_1, params.inertia_table
    r1, r2 = params.radius_pinion_1, params.radius_table
    against_each_other = math.sqrt(k * r1 ** 2 / i1)
    against_table = math.sqrt(k * r1 ** 2 / i1 + 2.0 * k * r2 ** 2 / i2)
    model = linearize(params)
    assert model.point.contact == (ContactBranch.FORWARD, ContactBranch.REVERSE)
    lam = np.sort(np.abs(np.linalg.eigvals(model.a)))
    assert np.all(lam[:2] <= 1e-6 * against_table)                 # the rigid body: 0, 0
    np.testing.assert_allclose(lam[2:4], against_each_other, rtol=1e-6)
    np.testing.assert_allclose(lam[4:], against_table, rtol=1e-6)
    modes = model.modes()
    assert [m.shape for m in modes] == ['rigid body',
                                        'pinions against each other (table nearly still)',
                                        'pinions against the table']
    assert modes[0].frequency == 0.0
    np.testing.assert_allclose([m.frequency for m in modes[1:]],
                               [against_each_other, against_table], rtol=1e-6)
    assert all(abs(m.damping) < 1e-9 for m in modes[1:])


def _jacobian(params: TableParams, t: float, x: np.ndarray, torque: float, direction: int,
              load: float) -> tuple[np.ndarray, np.ndarray]:
    """Central differences of the model's right-hand side in x and in (torque, load)."""
    packed = pack(params)

    def f(y, u):
        # the mechanical state, then the drives' lagged torques (unused with no lag)
        return np.array(rhs(t, (*y, 0.0, 0.0), packed,
                            Drive(u[0], float(direction), u[1])))[:6]

    u = np.array([torque, load])
    scale_x = np.array([1e-9, 1e-9, 1e-9, 1e-6, 1e-6, 1e-6])
    a = np.column_stack([(f(x + e, u) - f(x - e, u)) / (2.0 * e.sum())
                         for e in np.diag(scale_x)])
    b = np.column_stack([(f(x, u + e) - f(x, u - e)) / (2.0 * e.sum())
                         for e in np.diag([1e-3, 1e-3])])
    return a, b


@pytest.mark.parametrize('torque, load, direction, table_damping, mode', [
    (0.0, 0.0, 1, 0.0, Mode.ANTI_BACKLASH),          # the preload equilibrium
    (100.0, 0.0, 1, 500.0, Mode.ANTI_BACKLASH),      # steady rotation, drive below its line
    (100.0, 0.0, -1, 50.0, Mode.ANTI_BACKLASH),      # steady rotation on the drive line, path 3
    (150.0, 300.0, 1, 500.0, Mode.CONVENTIONAL),     # conventional, against a load
])
def test_a_and_b_are_the_jacobian_of_the_right_hand_side(torque, load, direction,
                                                         table_damping, mode):
    """In `time` phase the mesh stiffness is K(ω_e·t): at a t where the fluctuation is
    zero, K is the mean stiffness, and the Jacobian of the full right-hand side (STE,
    stiffness fluctuation and all) is the averaged model's A."""
    params = PAPER.replace(mesh_phase=MeshPhase.TIME, table_damping=table_damping, mode=mode,
                           mesh_stiffness_phase=0.3, ste_phases=(0.7,))
    model = linearize(params, torque, load, direction)
    t = (0.5 * math.pi - params.mesh_stiffness_phase) / params.mesh_frequency
    eps = params.ste_amplitudes[0] * math.sin(params.mesh_frequency * t + params.ste_phases[0])
    x = np.array(model.point.state)
    # the same mean deflections at time t: the pinions carry the STE
    x[0] += eps / params.radius_pinion_1
    x[2] += eps / params.radius_pinion_3
    a, b = _jacobian(params, t, x, torque, direction, load)
    np.testing.assert_allclose(model.a, a, rtol=1e-6, atol=1e-6 * np.abs(a).max())
    np.testing.assert_allclose(model.b, b, rtol=1e-6, atol=1e-6 * np.abs(b).max())
    if model.point.drive_piece == DrivePiece.LINE:
        assert not np.any(model.b[:, 0])             # the command changes nothing there


def test_a_is_the_stability_checks_linearization_where_both_agree():
    """`stiffest_linearization` (the RK4 step limit's) with no fluctuation and no STE and an
    ideal torque source is the model at the preload equilibrium."""
    params = PAPER.replace(mesh_stiffness_amplitude=0.0, ste_amplitudes=(0.0,),
                           drive_no_load_speed=0.0, table_damping=3.0)
    # the speeds' columns are differences of 1e-4 rad/s steps (AVERAGE_STEPS): their
    # roundoff is eps·(T_p + …)/(I1·h) ≈ 5e-8 1/s on the pinions' rows
    np.testing.assert_allclose(linearize(params).a, stiffest_linearization(params), rtol=1e-12,
                               atol=1e-6)


@pytest.mark.parametrize('table_damping, piece', [(500.0, DrivePiece.COMMAND),
                                                  (50.0, DrivePiece.LINE)])
def test_the_steady_rotation_is_where_the_simulation_settles(table_damping, piece):
    params = PAPER.replace(mesh_stiffness_amplitude=0.0, ste_amplitudes=(0.0,),
                           table_damping=table_damping)
    point = operating_point(params, 100.0, 40.0, 1)
    assert point.drive_piece == piece and point.rotating
    simulation = Simulation.from_values(params.as_dict(), command_timeout=0.0)
    simulation.reset()
    o = simulation.step(torque=100.0, load=40.0)
    for _ in range(1500):
        o = simulation.step()
    assert abs(o.velocity[1] - point.state[4]) <= 1e-4 * abs(point.state[4])
    np.testing.assert_allclose(o.mesh_force, point.mesh_force, rtol=1e-4)


def test_contact_state_said_and_warned():
    conventional = linearize(PAPER.replace(mode=Mode.CONVENTIONAL))
    assert conventional.point.contact == (ContactBranch.GAP, ContactBranch.DISENGAGED)
    assert any('no force' in w for w in conventional.point.warnings)
    assert 'pinion 3 alone (disengaged)' in [m.shape for m in conventional.modes()]
    at_rest = linearize(PAPER)
    assert not at_rest.point.warnings
    assert any('on its forward flank' in line for line in at_rest.point.describe())
    # in steady rotation the STE lifts the flanks of the paper's table: the model warns,
    # and the simulation there does cross a contact change (a mesh force changes sign)
    spinning = linearize(PAPER, 100.0, 0.0, 1)
    assert any('near a contact change' in w for w in spinning.point.warnings)
    run = Simulation(PAPER).run(lambda o: 100.0, 1.0)
    late = run.mesh_force[len(run) // 2:]
    assert late[:, 0].min() < 0.0 or late[:, 1].max() > 0.0


def test_python_control_gives_the_same_poles(tmp_path):
    control = pytest.importorskip('control')
    model = linearize(PAPER, 50.0, 50.0 * PAPER.radius_table / PAPER.radius_pinion_1)
    path = tmp_path / 'model.npz'
    model.save(path)
    data = np.load(path)          # plain arrays: no pickle needed
    system = control.ss(data['A'], data['B'], data['C'], data['D'],
                        states=list(data['states']), inputs=list(data['inputs']),
                        outputs=list(data['outputs']))
    ours = np.sort_complex(np.linalg.eigvals(model.a))
    theirs = np.sort_complex(np.asarray(control.poles(system)))
    np.testing.assert_allclose(theirs, ours, rtol=1e-9, atol=1e-6)
    loaded = pickle.loads(model.control_pickle())
    np.testing.assert_allclose(np.sort_complex(np.asarray(loaded.poles())), ours, rtol=1e-9,
                               atol=1e-6)
    assert list(loaded.input_labels) == list(INPUTS)
    assert list(loaded.output_labels) == list(OUTPUTS)
    # and the same frequency response
    hz = np.array([0.5, 50.0, 220.0])
    theirs = np.stack([np.asarray(system(2j * math.pi * f)) for f in hz], axis=-1)
    np.testing.assert_allclose(theirs, model.response(hz), rtol=1e-9)


@pytest.mark.ros
def test_the_executable_writes_named_matrices(tmp_path):
    out = tmp_path / 'model.npz'
    proc = installed('linearize', '--torque', '20', '--load', '149.23', '-o', out)
    assert proc.returncode == 0, proc.stderr
    for text in ('contact assumed: mesh 1 on its forward flank', 'pinions against the table',
                 'rigid body', 'rad/s', 'Hz'):
        assert text in proc.stdout
    data = np.load(out)
    assert tuple(data['states']) == STATES and tuple(data['inputs']) == INPUTS
    assert tuple(data['outputs']) == OUTPUTS
    assert data['A'].shape == (6, 6) and data['B'].shape == (6, 2)
    assert data['C'].shape == (7, 6) and data['D'].shape == (7, 2)
    mat = tmp_path / 'model.mat'
    assert installed('linearize', '-o', mat).returncode == 0
    from scipy.io import loadmat
    loaded = loadmat(mat)
    np.testing.assert_array_equal(loaded['A'], linearize(PAPER).a)
    assert [str(s[0]) for s in loaded['outputs'].ravel()] == list(OUTPUTS)
    launcher = Path(sys.prefix) / 'lib' / 'screwgear_ros' / 'linearize'
    assert launcher.is_file() and '/../../bin/linearize"' in launcher.read_text()


@pytest.mark.ros
@pytest.mark.parametrize('args, says', [
    (['--torque', '401'], 'max_torque'),
    (['--torque', 'nan'], 'finite'),
    (['--torque', '10'], 'accelerates the table forever'),   # ideal source, nothing holds it
    (['--params', '/no/such/file.yaml'], 'cannot read'),
    (['--params', 'BAD'], 'mesh_stiffness_amplitude'),
    (['-o', '/no/such/dir/model.npz'], 'cannot write'),
])
def test_bad_input_exits_2_with_the_reason(tmp_path, args, says):
    if 'BAD' in args:
        bad = tmp_path / 'bad.yaml'
        bad.write_text('/**:\n  ros__parameters:\n    mesh_stiffness_amplitude: 2.0e7\n')
        args = [str(bad) if a == 'BAD' else a for a in args]
    if args[0] == '--torque' and args[1] == '10':
        params = tmp_path / 'ideal.yaml'
        params.write_text('/**:\n  ros__parameters:\n    drive_no_load_speed: 0.0\n')
        args = [*args, '--params', str(params)]
    if '-o' not in args:
        args = [*args, '-o', str(tmp_path / 'm.npz')]
    proc = installed('linearize', *args)
    assert proc.returncode == 2
    assert says in proc.stderr and 'Traceback' not in proc.stderr + proc.stdout


def test_bad_values_in_the_core_are_refused_as_operating_point_values():
    for kwargs in ({'torque': -1.0}, {'direction': 0}, {'load': math.inf},
                   {'load': 1e9}):
        with pytest.raises(OperatingPointRefused):
            linearize(PAPER, **kwargs)


def test_valid_inputs_without_a_steady_motion_are_no_steady_state():
    # no drive torque, no table damping: any load accelerates the table for ever
    with pytest.raises(NoSteadyState, match='accelerates the table forever') as caught:
        operating_point(PAPER.replace(table_damping=0.0), load=10.0)
    assert not isinstance(caught.value, OperatingPointRefused)
    assert isinstance(caught.value, ScrewgearError) and isinstance(caught.value, ValueError)


def test_the_frozen_mesh_is_the_average_without_mesh_excitation():
    params = PAPER.replace(mesh_stiffness_amplitude=0.0, ste_amplitudes=(0.0,))
    for torque, load in ((0.0, 0.0), (50.0, 50.0 * params.radius_table / params.radius_pinion_1)):
        average = linearize(params, torque, load)
        frozen = linearize(params, torque, load, 1, 'frozen')
        assert frozen.mesh.value == 'frozen'
        np.testing.assert_allclose(frozen.a, average.a, rtol=1e-6, atol=1e-6 * np.abs(average.a).max())
        np.testing.assert_allclose(frozen.b, average.b, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(frozen.c, average.c, rtol=1e-12)


@pytest.mark.ros
def test_a_frozen_mesh_is_refused_where_the_phase_advances(tmp_path):
    with pytest.raises(MeshModelUnsupported, match='static operating point'):
        linearize(PAPER, 100.0, 0.0, 1, 'frozen')
    with pytest.raises(MeshModelUnsupported, match='angle mesh phase'):
        linearize(PAPER.replace(mesh_phase=MeshPhase.TIME), mesh='frozen')
    proc = installed('linearize', '--mesh', 'frozen', '--torque', '100', '-o', tmp_path / 'm.npz')
    assert proc.returncode == 2 and 'static operating point' in proc.stderr
    proc = installed('linearize', '--mesh', 'frozen', '--torque', '20', '--load', 'hold',
                     '-o', tmp_path / 'm.npz')
    assert proc.returncode == 0 and 'frozen at the rest angle' in proc.stdout
    assert str(np.load(tmp_path / 'm.npz')['mesh']) == 'frozen'


# The paper report's design cases (paper/design.py): the frozen mesh at rest under the
# holding torque, at several preloads, preload stiffnesses and stiffness fluctuations.
_REPORT_CASES = [PAPER.replace(preload_torque=100.0), PAPER,
                 PAPER.replace(preload_stiffness=1e7),
                 PAPER.replace(mesh_stiffness_amplitude=0.2 * PAPER.mesh_stiffness_mean)]


@pytest.mark.parametrize('case', range(len(_REPORT_CASES)))
def test_the_frozen_rest_state_is_found_from_starts_a_few_ulps_apart(case, monkeypatch):
    """Whether Newton finds the rest state must not depend on roundoff: started from the
    preload equilibrium nudged by −6…6 float spacings in every angle (what another CPU's or
    BLAS kernel's roundoff does to it), it converges every time, to oscillating modes that
    agree far closer than anything the report prints. A stopping rule below roundoff
    (|step| ≤ 1e-15·|x|, issue #47) failed 73 of 156 such starts."""
    import importlib
    module = importlib.import_module('screwgear_ros.design.linearize')
    from screwgear_ros.design.frequency import Input, default_bias
    from screwgear_ros.physics.equilibrium import equilibrium_state
    params = _REPORT_CASES[case]
    torque, load = default_bias(params, Input.TORQUE, 10.0, None, None, 1)
    reference = [m.frequency for m in linearize(params, torque, load, 1, 'frozen').modes()
                 if m.oscillating]
    assert len(reference) == 2
    for nudge in range(-6, 7):
        def start(p, nudge=nudge):
            x = np.array(equilibrium_state(p), dtype=float)
            x[:3] += nudge * np.spacing(x[:3])
            return x
        monkeypatch.setattr(module, 'equilibrium_state', start)
        model = linearize(params, torque, load, 1, 'frozen')
        found = [m.frequency for m in model.modes() if m.oscillating]
        np.testing.assert_allclose(found, reference, rtol=1e-7, err_msg=f'nudge {nudge}')
        # and it is a rest: the model's own accelerations there are nothing beside the
        # elastic torques (A·x), with the inputs held
        x = np.array(model.point.state)
        u = np.array([model.point.torque, model.point.load])
        acceleration = module._derivative(x, u, model.point, pack(params))[3:]
        acting = np.abs(model.a[3:, :3]) @ np.abs(x[:3]) + np.abs(model.b[3:]) @ np.abs(u)
        assert np.all(np.abs(acceleration) <= 1e-9 * acting), f'nudge {nudge}'
