"""``identify`` as installed, on a recording through the node: demo_controller around
table_sim in lockstep on the realistic table with a changed table inertia, fitted from
the preset's value on worker processes; the fitted file drives ``linearize`` and
``frequency_response``; bad input exits 2 with the reason and Ctrl-C writes the best
point so far, marked unfinished."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from bag_runs import installed
from identify_truth import PRESET, TRUTH, copy_topics, truth_simulation, write_base
from ros_procs import record_lockstep_demo

from screwgear_ros import Simulation
from screwgear_ros.inprocess.simulation import file_values

TICK_NS = 1_000_000
INERTIA = 48.0           # kg·m², the preset's (the paper's) is 46.101


@pytest.fixture(scope='module')
def node_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    workdir = tmp_path_factory.mktemp('identify_node')
    values = {**file_values(PRESET), 'inertia_table': INERTIA, 'command_timeout': 0.0}
    return record_lockstep_demo(workdir, values, [0.02, -0.02], 0.4, 1200, TICK_NS,
                                'test_identify_node')


def _no_traceback(result: subprocess.CompletedProcess) -> None:
    assert 'Traceback' not in result.stdout + result.stderr, result.stderr


def _first_iteration(process: subprocess.Popen, seconds: float) -> bytes:
    """What ``process`` wrote to stderr until its progress bar showed a first iteration
    (fails if it ends first, or none comes within ``seconds``)."""
    seen, deadline = b'', time.monotonic() + seconds
    while b'iteration=1' not in seen and time.monotonic() < deadline:
        ready, _, _ = select.select([process.stderr], [], [], 1.0)
        if ready:
            seen += os.read(process.stderr.fileno(), 4096)
        assert process.poll() is None, seen.decode()
    assert b'iteration=1' in seen, f'no iteration within {seconds:g} s'
    return seen


@pytest.mark.ros
def test_identify_fits_a_node_recording_and_the_fit_drives_the_design_tools(node_bag,
                                                                          tmp_path):
    base = write_base(tmp_path / 'base.yaml', list(TRUTH))   # the preset, no timeout
    fitted = tmp_path / 'fitted.yaml'
    result = installed('identify', node_bag, '--params', base, '--fit', 'inertia_table',
                       '--workers', '2', '--starts', '2', '--no-progress', '-o', fitted)
    _no_traceback(result)
    assert result.returncode == 0, result.stderr
    value = Simulation.from_yaml(fitted).params.inertia_table
    assert abs(value / INERTIA - 1) < 0.01, value
    assert 'inertia_table = ' in result.stdout and 'fit % (fit)' in result.stdout
    assert (tmp_path / 'fitted_report.md').is_file() and (tmp_path / 'fitted_report.png').is_file()
    # at rest the fitted table's bearings are stuck: linearize refuses that unless the
    # friction is left out, said so (design.friction_state)
    model = installed('linearize', '--params', fitted, '--friction', 'ignore', '-o',
                      tmp_path / 'table.npz')
    assert model.returncode == 0, model.stderr
    bode = installed('frequency_response', '--params', fitted, '--points', '3', '--from', '5',
                     '--to', '20', '-o', tmp_path / 'bode')
    assert bode.returncode == 0, bode.stderr
    assert (tmp_path / 'bode.csv').is_file()


@pytest.mark.ros
def test_bad_input_exits_2_naming_the_problem(node_bag, tmp_path):
    no_commands = copy_topics(node_bag, tmp_path / 'no_commands', ['joint_states'])
    cases = [
        ([node_bag, '--fit', 'inertia_tabel'], 'inertia_tabel is not a parameter'),
        ([node_bag, '--fit', 'mode'], 'read-only'),
        ([node_bag, '--fit', 'backlash', '--bounds', 'backlash=0:1'], 'declared range'),
        ([no_commands, '--fit', 'inertia_table'], 'no commands'),
        ([node_bag, '--fit', 'inertia_table', '--joints', 'table=axis'], 'axis'),
    ]
    for args, message in cases:
        result = installed('identify', *args, '--params', PRESET, '--no-progress',
                           '-o', tmp_path / 'fitted.yaml')
        _no_traceback(result)
        assert result.returncode == 2, (args, result.stderr)
        assert result.stderr.startswith('identify: ') and message in result.stderr, (
            args, result.stderr)
    assert not (tmp_path / 'fitted.yaml').exists()


@pytest.mark.ros
def test_ctrl_c_writes_the_best_point_so_far_marked_unfinished(node_bag, tmp_path):
    fitted = tmp_path / 'fitted.yaml'
    base = write_base(tmp_path / 'base.yaml', list(TRUTH))
    process = subprocess.Popen(
        ['identify', str(node_bag), '--params', str(base), '--fit',
         'inertia_table,mesh_stiffness_mean', '--max-evaluations', '200', '-o', str(fitted)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        seen = _first_iteration(process, 300)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=120)
    finally:
        process.kill()
    text = (seen + err).decode()
    assert process.returncode == 130, text
    assert 'Traceback' not in text and 'marked unfinished' in text
    written = fitted.read_text(encoding='utf-8')
    assert written.startswith('# UNFINISHED')
    assert Simulation.from_yaml(fitted).params.inertia_table != \
        Simulation.from_yaml(PRESET).params.inertia_table


@pytest.mark.ros
def test_ros2_run_finds_identify():
    """$prefix/lib/screwgear_ros/identify, what `ros2 run screwgear_ros identify` runs."""
    launcher = Path(sys.prefix) / 'lib' / 'screwgear_ros' / 'identify'
    proc = subprocess.run([str(launcher), '--help'], capture_output=True, text=True,
                          check=False, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith('usage: identify') and '--fit' in proc.stdout


@pytest.mark.ros
def test_ctrl_c_to_the_terminal_s_group_stops_worker_processes_without_tracebacks(tmp_path):
    """SIGINT to the whole process group, as a terminal's Ctrl-C sends it: the parent
    writes the best point so far (exit 130) and no worker prints a traceback."""
    bag = tmp_path / 'tiny'
    truth_simulation().run(lambda o: 5.0 if o.time < 0.4 else -5.0, 0.8, record=bag)
    base = write_base(tmp_path / 'base.yaml', ['inertia_table', 'mesh_damping'])
    written = tmp_path / 'group.yaml'
    process = subprocess.Popen(
        [sys.executable, '-c', ('import sys; from screwgear_ros.cli.identify import main; '
         'sys.exit(main())'), str(bag), '--params', str(base), '--fit',
         'inertia_table,mesh_damping', '--workers', '2', '--starts', '100', '-o',
         str(written)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        start_new_session=True)
    try:
        seen = _first_iteration(process, 120)
        os.killpg(process.pid, signal.SIGINT)
        _, err = process.communicate(timeout=120)
    finally:
        process.kill()
    text = (seen + err).decode()
    assert process.returncode == 130, text
    assert 'Traceback' not in text and 'KeyboardInterrupt' not in text, text
    assert written.read_text(encoding='utf-8').startswith('# UNFINISHED')
