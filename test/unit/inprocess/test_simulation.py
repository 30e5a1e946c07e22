"""screwgear_ros.Simulation: construction from the node's parameter sources, step and run
semantics, refused commands, recording that check_run passes."""

from __future__ import annotations

import math
import pickle
import subprocess
import sys

import numpy as np
import pytest
import yaml
from bag_runs import installed_check_run
from paths import ROOT

from screwgear_ros import InputRejected, ParameterError, Simulation
from screwgear_ros.bag.reader import read_run
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.commands import apply_command
from screwgear_ros.sim.parameter_set import split_parameters
from screwgear_ros.sim.plant import DriveInput

CONFIG = ROOT / 'config'
ROS = ('rclpy', 'rosidl_runtime_py', 'std_msgs', 'sensor_msgs')


def _imports(code: str) -> list[str]:
    """The ROS modules loaded by ``code`` in a fresh interpreter."""
    probe = (f'{code}\nimport sys\n'
             f'print(sorted(m for m in sys.modules if m.split(".")[0] in {ROS!r}))')
    proc = subprocess.run([sys.executable, '-P', '-c', probe], capture_output=True, text=True,
                          timeout=300, check=True)
    return eval(proc.stdout.strip().splitlines()[-1])   # a printed list of names


@pytest.mark.ros
def test_import_screwgear_ros_loads_no_ros():
    assert _imports('import screwgear_ros') == []
    assert _imports('import screwgear_ros\nscrewgear_ros.Simulation().reset()') == []
    assert _imports('from screwgear_ros import Simulation\n'
                    'Simulation().run(lambda o: 10.0, 0.01)') == []


def test_from_yaml_takes_the_node_parameter_file_and_overrides(tmp_path):
    assert (Simulation.from_yaml(CONFIG / 'paper.yaml').params,
            Simulation.from_yaml(CONFIG / 'paper.yaml').settings) == (TableParams(),
                                                                     SimSettings())
    sim = Simulation.from_yaml(CONFIG / 'paper.yaml', backlash=2e-5, dt=2.5e-5,
                               publish_rate=2000.0)
    assert (sim.params.backlash, sim.settings.dt, sim.settings.publish_rate) == (2e-5, 2.5e-5,
                                                                                 2000.0)
    # a node-name key; another node's section is not table_sim's
    path = tmp_path / 'p.yaml'
    path.write_text(yaml.safe_dump({
        'table_sim': {'ros__parameters': {'preload_torque': 300.0}},
        'demo_controller': {'ros__parameters': {'kp': 1.0}}}))
    sim = Simulation.from_yaml(path)
    assert sim.params.preload_torque == 300.0 and sim.params.backlash == TableParams().backlash
    assert sim.with_values(backlash=0.0).params.preload_torque == 300.0


@pytest.mark.parametrize('values', [{'backlash': -1.0}, {'dt': 5e-3, 'publish_rate': 100.0}, {'publish_rate': 3000.0},
                                    {'mode': 'sideways'}, {'no_such_parameter': 1.0},
                                    {'inertia_table': 'heavy'}])
def test_a_refused_value_gets_the_nodes_message(values, tmp_path):
    with pytest.raises(ParameterError) as expected:     # what the node itself says
        from screwgear_ros.sim.parameter_set import default_values
        split_parameters({**default_values(), **values})
    with pytest.raises(ParameterError) as got:
        Simulation.from_values(**values)
    assert str(got.value) == str(expected.value)
    path = tmp_path / 'p.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': values}}))
    with pytest.raises(ParameterError) as from_file:
        Simulation.from_yaml(path)
    assert str(expected.value.rule) in str(from_file.value) and str(path) in str(from_file.value)


def test_step_applies_commands_at_the_next_ticks_first_step():
    sim = Simulation.from_values(publish_rate=500.0, command_timeout=0.0)
    first = sim.reset()
    preload = sim.params.preload_torque
    assert (first.step, first.time, first.effort) == (0, 0.0, (preload, 0.0, -preload))
    o = sim.step(120.0)
    assert o.step == 40 and o.time == pytest.approx(2e-3)
    assert o.effort[0] == 120.0 + preload            # drive torque on pinion 1 in force
    o = sim.step(-80.0)                                # a reversal: path 3 drives
    assert o.active_path == 3 and o.effort[2] == -(80.0 + preload)
    sim.step(load=500.0)
    assert sim.session.plant.input == DriveInput(80.0, -1, 500.0)
    o = sim.step(torque=50.0, direction=1)
    assert o.active_path == 1 and o.effort[0] == 50.0 + preload
    assert sim.session.rejected == {k: 0 for k in sim.session.rejected}


def _state(sim: Simulation) -> tuple:
    return (sim.session.step, sim.session.plant.input, tuple(sim.session.plant.state))


@pytest.mark.parametrize('command', [{'effort': 1000.0}, {'effort': math.nan},
                                     {'torque': -1.0}, {'direction': 0},
                                     {'load': 1e9}, {'effort': 100.0, 'load': 1e9}])
def test_a_refused_command_raises_the_nodes_message_and_changes_nothing(command):
    sim = Simulation.from_values(command_timeout=0.0)
    sim.reset()
    sim.step(50.0)
    before = _state(sim)
    topic, value = {'effort': ('cmd_effort', [command.get('effort')]),
                    'torque': ('cmd_torque', command.get('torque')),
                    'direction': ('cmd_direction', command.get('direction')),
                    'load': ('load_torque', command.get('load'))}[list(command)[-1]]
    with pytest.raises(InputRejected) as expected:      # what the node says about it
        apply_command(DriveInput(), topic, value, sim.params)
    with pytest.raises(InputRejected) as got:
        sim.step(**command)
    assert str(got.value) == str(expected.value)
    assert _state(sim) == before
    # and the next tick is the one a simulation that never saw it makes
    other = Simulation.from_values(command_timeout=0.0)
    other.reset()
    other.step(50.0)
    assert sim.step() == other.step()


def test_step_before_reset_says_so():
    with pytest.raises(RuntimeError, match='reset'):
        Simulation().step(1.0)


def test_run_closes_the_loop_one_tick_late_and_returns_arrays():
    sim = Simulation.from_values(command_timeout=0.0, table_damping=8867.0)
    seen = []

    def controller(o):
        seen.append(o.step)
        return 200.0 if o.step < 100 else None   # then no command: the last stays in force

    run = sim.run(controller, 0.01)
    assert len(run) == 11 and seen == list(run.step[:10])
    np.testing.assert_array_equal(run.step, np.arange(11) * 20)
    np.testing.assert_array_equal(run.time, run.step * 50e-6)
    assert np.all(run.effort[1:, 0] == 200.0 + 350.0) and run.effort[0, 0] == 350.0
    assert np.isnan(run.command[5:]).all() and (run.command[:5] == 200.0).all()
    # the same ticks, stepped by hand, are the same bits
    sim.reset()
    rows = [sim.step(200.0 if k < 5 else None) for k in range(10)]
    assert np.array_equal(run.position[1:], np.array([o.position for o in rows]))
    assert np.array_equal(run.transmission_error[1:], [o.transmission_error for o in rows])
    assert np.array_equal(run.mesh_force[1:], np.array([o.mesh_force for o in rows]))


def test_run_is_deterministic_and_its_inputs_pickle():
    sim = Simulation.from_yaml(CONFIG / 'paper.yaml', table_damping=8867.0)
    clone = pickle.loads(pickle.dumps(sim))

    def pd(o):
        return max(-300.0, min(300.0, 3000.0 * (0.01 - o.position[1]) - 200.0 * o.velocity[1]))

    a, b = sim.run(pd, 0.2), clone.run(pd, 0.2)
    assert a.observed.tobytes() == b.observed.tobytes()
    # after a run too (a simulation pickles as its parameters), and scenarios pickle
    again = pickle.loads(pickle.dumps(sim)).run(pd, 0.2)
    assert again.observed.tobytes() == a.observed.tobytes()
    from screwgear_ros.inprocess.scenario import load_scenario
    scenario = load_scenario(CONFIG.parent / 'docs' / 'examples' / 'demo_position_steps.yaml')
    assert pickle.loads(pickle.dumps(scenario)) == scenario


def test_a_refused_effort_in_run_ends_it_with_the_recording_closed(tmp_path):
    sim = Simulation.from_values(command_timeout=0.0)
    with pytest.raises(InputRejected, match=r'\|effort\| must be <= 400'):
        sim.run(lambda o: 100.0 if o.step < 200 else 1000.0, 0.05, record=tmp_path / 'bag')
    run = read_run(tmp_path / 'bag')          # a complete, readable bag of the ticks done
    # the tick the refused effort was for ran with the last valid command, as in the node
    assert list(run.joint_states.steps) == [20 * k for k in range(12)]
    assert run.joint_states.values[-1, 6] == 100.0 + 350.0


@pytest.mark.ros
def test_a_recorded_run_passes_check_run(tmp_path):
    sim = Simulation.from_values(table_damping=8867.0, publish_rate=500.0)

    def pd(o):
        target = 0.01 if o.time < 0.15 else -0.01
        return max(-300.0, min(300.0, 3000.0 * (target - o.position[1]) - 200.0 * o.velocity[1]))

    run = sim.run(pd, 0.3, record=tmp_path / 'bag')
    recorded = read_run(tmp_path / 'bag')
    np.testing.assert_array_equal(recorded.joint_states.steps, run.step)
    assert recorded.joint_states.values.tobytes() == run.joint_states.tobytes()
    assert recorded.transmission_error.values[:, 0].tobytes() == \
        run.transmission_error.tobytes()
    assert 3 in recorded.active_path.values[:, 0]
    # the replay of its recorded commands (what replay_run plays) makes the same bits
    from screwgear_ros.runs.replay_in_process import replay_in_process
    assert replay_in_process(recorded).joint_states.tobytes() == run.joint_states.tobytes()
    proc = installed_check_run(tmp_path / 'bag')
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize('values', [
    {'effort_deadband': 2.0, 'command_timeout': 0.02},
    {'encoder_counts_table': 4096, 'position_noise_pinion_1': 1e-4, 'sensor_seed': 3,
     'velocity_filter_cutoff_table': 300.0, 'measurement_delay_table': 2}],
    ids=['deadband-timeout', 'sensors'])
def test_a_run_gives_the_bits_it_records(values, tmp_path):
    """A run that is not recorded ticks the session's fast closed-loop tick, a recorded
    one the full Tick the recording writes (which the lockstep node's bits are compared
    with): both give the same samples, with the drive reversing, silent ticks, answers
    in the deadband, scheduled commands (one refused) and a reset. The controller sees
    what the session's outputs and sensors say of each sample."""
    from screwgear_ros.inprocess.simulation import Observation
    from screwgear_ros.sim.events import Command, Reset
    seen = []

    def pd(o):
        session = sim.session
        out, measured = session.last_outputs, session.measured
        seen.append(o == Observation(
            out.time, out.step, measured.position, measured.velocity, out.effort,
            out.transmission_error, out.delta, out.delta_rate, out.mesh_force,
            out.active_path, session.plant.fault, out.position, out.velocity))
        if 40 <= o.step // 20 < 70:
            return None                               # silent: command_timeout may act
        if o.step // 20 % 17 == 5:
            return 0.5                                # within the deadband of one case
        target = 0.01 if o.time < 0.1 else -0.01
        wanted = 3000.0 * (target - o.position[1]) - 200.0 * o.velocity[1]
        return max(-300.0, min(300.0, wanted))

    events = [Command('load_torque', 40.0, step=1_000), Command('cmd_torque', 1e6, step=2_400),
              Reset(step=3_000)]
    sim = Simulation.from_values(table_damping=8867.0, **values)
    plain = sim.run(pd, 0.2, events=events)
    recorded = sim.run(pd, 0.2, record=tmp_path / 'bag', events=events)
    for name in ('step', 'observed', 'path', 'direction', 'command', 'measured'):
        a, b = getattr(plain, name), getattr(recorded, name)
        assert (a is None and b is None) or a.tobytes() == b.tobytes(), name
    assert plain.rejected == recorded.rejected and len(plain.rejected) == 1
    assert {-1, 1} <= set(plain.direction.tolist()) and np.isnan(plain.command).any()
    assert (plain.measured is None) == ('sensor_seed' not in values)
    assert len(seen) == 2 * (len(plain) - 1) and all(seen)


@pytest.mark.parametrize('answer', ['ten', [1.0], True, math.inf])
def test_an_answer_that_is_no_number_ends_the_run_with_the_nodes_refusal(answer):
    """Whatever the controller returns is judged by the session as the node judges a
    cmd_effort: InputRejected with the node's message, never another error."""
    sim = Simulation.from_values(command_timeout=0.0)
    with pytest.raises(InputRejected) as expected:      # what the node says about it
        apply_command(DriveInput(), 'cmd_effort', [answer], sim.params)
    with pytest.raises(InputRejected) as got:
        sim.run(lambda o: 50.0 if o.step < 100 else answer, 0.02)
    assert str(got.value) == str(expected.value)
