"""run_scenario and scenario files: every test scenario and example runs; a broken file
gets a message naming its line and exit 2, never a traceback; the metrics against
closed forms."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from bag_runs import installed, installed_check_run
from paths import ROOT

from screwgear_ros import Simulation
from screwgear_ros.bag.reader import read_run
from screwgear_ros.inprocess.metrics import SETTLING_BAND, run_metrics
from screwgear_ros.inprocess.scenario import ScenarioError, SetpointProfile, load_scenario
from screwgear_ros.params.table import ParameterError
from screwgear_ros.sim.parameter_set import default_values, split_parameters

SCENARIOS = sorted((ROOT / 'test' / 'data' / 'scenarios').glob('*.yaml'))
EXAMPLES = sorted(p for p in (ROOT / 'docs' / 'examples').glob('*.yaml')
                  if not p.stem.endswith('_sweep'))        # sweep files: test_sweep.py


def test_there_are_scenarios_to_run():
    assert len(SCENARIOS) >= 4 and len(EXAMPLES) >= 2


@pytest.mark.ros
@pytest.mark.parametrize('path', SCENARIOS + EXAMPLES, ids=lambda p: p.stem)
def test_run_scenario_runs_every_scenario(path):
    proc = installed('run_scenario', path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert 'max |TE|' in proc.stdout and 'peak mesh force' in proc.stdout
    scenario = load_scenario(path)
    if scenario.setpoint is not None:
        assert 'RMS tracking error' in proc.stdout
    if any(a.kind == 'cmd_direction' for a in scenario.actions):
        assert 'lost motion' in proc.stdout


def test_the_launcher_is_where_ros2_run_looks():
    import sys
    launcher = Path(sys.prefix) / 'lib' / 'screwgear_ros' / 'run_scenario'
    assert launcher.is_file() and '/../../bin/run_scenario"' in launcher.read_text()


@pytest.mark.ros
def test_a_recorded_scenario_passes_check_run_and_holds_its_actions(tmp_path):
    path = ROOT / 'test' / 'data' / 'scenarios' / 'load_steps_parameter_changes.yaml'
    proc = installed('run_scenario', path, '--record', tmp_path / 'bag', '--plot',
                     tmp_path / 'run.png')
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / 'run.png').stat().st_size > 10_000
    run = read_run(tmp_path / 'bag')
    schedule = load_scenario(path).schedule()
    assert [(type(e).__name__, e.step) for _, e in run.events] == \
        [(type(e).__name__, e.step) for e in schedule.events]
    checked = installed_check_run(tmp_path / 'bag')
    assert checked.returncode == 0, checked.stdout + checked.stderr
    again = installed('run_scenario', path, '--record', tmp_path / 'bag')
    assert again.returncode == 2 and 'exists' in again.stderr


def _node_refusal(**values) -> str:
    """What the node's own validation says of ``values`` (a scenario must say the same)."""
    with pytest.raises(ParameterError) as error:
        split_parameters({**default_values(), **values})
    return error.value.rule


BROKEN = {
    'unknown key': ('duration: 1.0\nactoins: []\n', 2, "unknown scenario key 'actoins'"),
    'unknown parameter': ('duration: 1.0\nparameters:\n  backlash: 1.0e-5\n  baklash: 2\n',
                          4, "'baklash'"),
    'bad parameter value': (('parameters: {publish_rate: 200.0}\nduration: 1.0\nactions:\n'
                            '  - {time: 0.5, parameters: {mesh_damping: -3.0}}\n'), 4,
                            _node_refusal(mesh_damping=-3.0)),
    'action after duration': (('duration: 1.0\nactions:\n  - {time: 0.2, cmd_torque: 10.0}\n'
                              '  - {time: 1.5, cmd_torque: 20.0}\n'), 4, 'after the end'),
    'wrong type': ('duration: 1.0\nactions:\n  - {time: 0.2, cmd_torque: fast}\n', 3,
                   'takes a number'),
    'duration a string': ('duration: long\n', 1, 'duration must be a finite number'),
    'refused command': ('duration: 1.0\nactions:\n  - {time: 0.2, cmd_torque: 900.0}\n', 3,
                        'max_torque'),
    'two actions in one': (('duration: 1.0\nactions:\n  - {time: 0.2, cmd_torque: 1.0, '
                           'reset: true}\n'), 3, 'exactly one'),
    'unknown action': ('duration: 1.0\nactions:\n  - {time: 0.2, cmd_speed: 1.0}\n', 3,
                       "unknown action 'cmd_speed'"),
    'unknown demo gain': (('duration: 1.0\ncontroller:\n  use: demo\n  parameters:\n'
                          '    kp: 1.0\n    kq: 2.0\n'), 6, "'kq'"),
    'controller not found': ('duration: 1.0\ncontroller: {use: "no_such_module:make"}\n', 2,
                             'cannot be loaded'),
    'setpoint profile': ('duration: 1.0\nsetpoint: {profile: zigzag}\n', 2,
                         "unknown setpoint profile 'zigzag'"),
    'setpoint points': (('duration: 1.0\nsetpoint:\n  profile: steps\n  points: [[0.0, 1.0], '
                        '[0.0, 2.0]]\n'), 4, 'must increase'),
    'not yaml': ('duration: 1.0\nactions: [\n', 3, 'not valid YAML'),
    'missing duration': ('parameters: {}\n', 1, 'needs a duration'),
}


@pytest.mark.ros
@pytest.mark.parametrize('name', BROKEN)
def test_a_broken_scenario_names_its_line(name, tmp_path):
    text, line, words = BROKEN[name]
    path = tmp_path / 'broken.yaml'
    path.write_text(text)
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    message = str(error.value)
    assert message.startswith(f'{path}: line {line}: ') and words in message, message
    proc = installed('run_scenario', path)
    assert proc.returncode == 2 and proc.stdout == ''
    assert proc.stderr.strip() == f'run_scenario: {message}'
    assert 'Traceback' not in proc.stderr


@pytest.mark.ros
def test_a_failing_controller_exits_2_with_the_reason(tmp_path):
    (tmp_path / 'bad_controller.py').write_text(
        'def make(setpoint):\n'
        '    def controller(o):\n'
        '        return 1e6 if o.step > 100 else 0.0\n'
        '    return controller\n')
    path = tmp_path / 's.yaml'
    path.write_text('duration: 0.5\ncontroller: {use: "bad_controller:make"}\n')
    proc = installed('run_scenario', path)
    assert proc.returncode == 2 and 'max_torque' in proc.stderr
    assert 'Traceback' not in proc.stderr


def test_a_replay_refuses_a_scenario_with_a_controller():
    from screwgear_ros.inprocess.scenario import schedule_from_scenario as replay_scenario
    with pytest.raises(ValueError, match='line 6: .*run_scenario'):
        replay_scenario(ROOT / 'docs' / 'examples' / 'demo_position_steps.yaml')


def test_setpoint_profiles():
    steps = SetpointProfile('steps', points=((0.5, 1.0), (1.0, -2.0)))
    assert [steps(t) for t in (0.0, 0.5, 0.99, 1.0, 5.0)] == [1.0, 1.0, 1.0, -2.0, -2.0]
    assert steps.steps(3.0) == [(1.0, 1.0, -2.0)]
    ramps = SetpointProfile('ramps', points=((0.0, 0.0), (2.0, 1.0)))
    assert ramps(1.0) == 0.5 and ramps(3.0) == 1.0 and ramps.steps(3.0) == []
    square = SetpointProfile('square', amplitude=0.1, period=2.0, offset=0.5)
    assert [square(t) for t in (0.0, 0.99, 1.0, 2.5)] == [0.6, 0.6, 0.4, 0.6]
    assert square.steps(2.5) == [(1.0, 0.6, 0.4), (2.0, 0.4, 0.6)]
    sine = SetpointProfile('sine', amplitude=2.0, frequency=0.25)
    assert sine(1.0) == pytest.approx(2.0)


def test_metrics_against_closed_forms():
    """A free table under a constant torque (no controller): the transmission error and the
    mesh force at rest are the preload's, F = T_p/r1; a reversal of a conventional table
    with backlash b crosses the gap 2b plus the change of elastic deflection ΔF/k."""
    sim = Simulation.from_values(mode='conventional', table_damping=8867.0,
                                 mesh_stiffness_amplitude=0.0, ste_amplitudes=[0.0],
                                 command_timeout=0.0, drive_no_load_speed=0.0)
    from screwgear_ros.sim.events import Command
    torque, r1, r2 = 200.0, sim.params.radius_pinion_1, sim.params.radius_table
    events = [Command('cmd_torque', torque, 0), Command('cmd_direction', -1, 20 * 1500)]
    run = sim.run(None, 3.0, events=events)
    m = run_metrics(run)
    k, b = sim.params.mesh_stiffness_mean, sim.params.backlash
    assert len(m.reversals) == 1 and m.reversals[0].time == pytest.approx(1.5)
    # settled: F = ±T/r1 on the mesh, δ = ±(b + F/k)
    expected = (2 * b + 2 * (torque / r1) / k) / r2
    assert m.reversals[0].lost_motion == pytest.approx(expected, rel=2e-3)
    assert m.peak_mesh_force[1] == 0.0 and m.peak_mesh_force[0] > torque / r1
    assert m.max_abs_te == pytest.approx(np.max(np.abs(run.transmission_error)))
    assert m.rms_tracking_error is None and m.steps == ()


def test_step_metrics_against_a_known_response():
    """Overshoot and settling time of a made-up second-order response, computed by hand."""
    class Fake:
        pass
    zeta, wn = 0.3, 20.0
    t = np.arange(0, 2.0, 1e-3)
    wd = wn * math.sqrt(1 - zeta ** 2)
    y = 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta ** 2)
                                      * np.sin(wd * t))
    run = Fake()
    run.settings = Simulation().settings
    run.params = Simulation().params
    run.time = t
    run.true_position = np.column_stack([0 * t, y, 0 * t])
    run.mesh_force = np.zeros((len(t), 2))
    run.transmission_error = np.zeros(len(t))
    run.direction = np.ones(len(t), dtype=np.int8)
    run.delta = np.zeros((len(t), 2))
    run.fault = None
    run.__len__ = None
    Fake.__len__ = lambda self: len(t)
    m = run_metrics(run, SetpointProfile('steps', points=((0.0, 1.0),)))
    step, = m.steps
    assert step.size == 1.0
    assert step.overshoot == pytest.approx(math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)),
                                           rel=1e-3)
    outside = np.flatnonzero(np.abs(y - 1) > SETTLING_BAND)
    assert step.settling_time == pytest.approx(t[outside[-1] + 1])
    assert 3.5 / (zeta * wn) < step.settling_time * 1.3      # the classic estimate, roughly


@pytest.mark.ros
def test_an_in_process_run_refuses_a_publish_rate_change(tmp_path):
    path = tmp_path / 's.yaml'
    path.write_text('duration: 0.2\nactions:\n  - {time: 0.1, parameters: {publish_rate: 500.0}}\n')
    proc = installed('run_scenario', path)
    assert proc.returncode == 2 and f'{path}: line 3: ' in proc.stderr and 'publish_rate' in proc.stderr
    assert load_scenario(path).schedule().events        # a replay still plays it
