"""sweep at its limits, through the installed executable: Ctrl-C while it validates, a
time limit that holds wherever a run spends its time, a scenario it cannot run in
process, more runs than it may build, results directories and run files that are not
what it wrote, a rerun of a finished sweep, and its progress in a log."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from bag_runs import installed

SCENARIO = 'parameters: {command_timeout: 0.0}\nduration: 0.05\n'
HEAD = 'scenario: scenario.yaml\nmetrics: [max_abs_te_m]\n'
SMALL = HEAD + 'grid:\n  backlash: [0.0, 1.0e-5, 2.0e-5]\n'


def _sweep_dir(tmp_path: Path, sweep: str, scenario: str = SCENARIO) -> Path:
    directory = tmp_path / 'case'
    directory.mkdir()
    (directory / 'scenario.yaml').write_text(scenario)
    (directory / 'sweep.yaml').write_text(sweep)
    return directory / 'sweep.yaml'


@pytest.mark.ros
def test_ctrl_c_while_the_runs_are_validated_exits_130(tmp_path):
    values = ', '.join(f'{k}.0e-9' for k in range(200))
    path = _sweep_dir(tmp_path, HEAD + f'grid:\n  backlash: [{values}]\n'
                      '  preload_torque: [' + ', '.join(f'{k}.0' for k in range(100)) + ']\n')
    proc = subprocess.Popen([sys.executable, '-P', '-m', 'screwgear_ros.cli.sweep', str(path),
                             '--out', str(tmp_path / 'out'), '--workers', '1'],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()              # said before the 20,000 runs are validated
    assert 'validating every run' in line and '20,000 runs' in line, line
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stdout + stderr
    assert 'Traceback' not in stderr and 'interrupted' in stderr
    assert not (tmp_path / 'out').exists()


CONTROLLERS = """\
import time


def slow_start(setpoint):
    time.sleep(60.0)            # before its first tick: no deadline check between ticks
    return lambda observation: None
"""


@pytest.mark.ros
def test_a_time_limit_holds_during_the_whole_run_in_this_process(tmp_path):
    scenario = 'duration: 0.05\ncontroller:\n  use: controllers:slow_start\n'
    path = _sweep_dir(tmp_path, HEAD + 'time_limit: 1.0\ngrid:\n  backlash: [0.0, 1.0e-5]\n',
                      scenario)
    (path.parent / 'controllers.py').write_text(CONTROLLERS)
    started = time.monotonic()
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '1', '--no-plot')
    elapsed = time.monotonic() - started
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(p.read_text()) for p in sorted((tmp_path / 'out' / 'runs').glob('*'))]
    assert [row['status'] for row in rows] == ['timeout', 'timeout'], rows
    assert all(row['wall_time'] < 5.0 for row in rows), rows
    assert elapsed < 50.0


@pytest.mark.ros
def test_a_scenario_that_changes_publish_rate_is_refused_before_any_run(tmp_path):
    scenario = ('duration: 0.05\nactions:\n  - {time: 0.02, parameters: {publish_rate: '
                '200.0}}\n')
    path = _sweep_dir(tmp_path, SMALL, scenario)
    run_scenario = installed('run_scenario', path.parent / 'scenario.yaml')
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '1')
    assert run_scenario.returncode == 2 and 'publish_rate' in run_scenario.stderr
    assert proc.returncode == 2 and 'Traceback' not in proc.stderr, proc.stderr
    assert 'line 3: changes publish_rate' in proc.stderr and 'line 1:' in proc.stderr
    assert not (tmp_path / 'out').exists()


@pytest.mark.ros
def test_a_billion_runs_are_counted_and_refused_at_once(tmp_path):
    sweep = HEAD + 'monte_carlo:\n  count: 1000000000\n  parameters:\n' \
        '    backlash: {uniform: [0.0, 1.0e-5]}\n'
    path = _sweep_dir(tmp_path, sweep)
    started = time.monotonic()
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '1')
    assert proc.returncode == 2 and 'Traceback' not in proc.stderr
    assert '1,000,000,000 runs' in proc.stderr and '--allow-runs 1000000000' in proc.stderr
    assert '5e+07 s of simulation' in proc.stderr
    assert time.monotonic() - started < 60.0


@pytest.mark.ros
def test_results_directories_it_did_not_write_are_refused_with_exit_2(tmp_path):
    path = _sweep_dir(tmp_path, SMALL)
    file = tmp_path / 'a_file'
    file.write_text('x')
    holding = tmp_path / 'holding'
    holding.mkdir()
    (holding / 'sweep.yaml').write_text('[1, 2]\n')
    for out, reason in ((file, 'is not a directory'), (Path('/dev/null'), 'is not a directory'),
                        (holding, 'holds no sweep')):
        proc = installed('sweep', path, '--out', out, '--workers', '1')
        assert proc.returncode == 2 and 'Traceback' not in proc.stderr, proc.stderr
        assert reason in proc.stderr
    assert file.read_text() == 'x'


@pytest.mark.ros
def test_a_finished_sweep_reruns_nothing_and_damaged_run_files_are_rerun(tmp_path):
    path = _sweep_dir(tmp_path, SMALL)
    out = tmp_path / 'out'
    first = installed('sweep', path, '--out', out, '--workers', '1')
    assert first.returncode == 0, first.stderr
    assert '\r' not in first.stderr and 'sweep: 3/3 runs (100 %)' in first.stderr
    kept = {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()}
    assert {'results.csv', 'results.parquet', 'summary.png'} <= set(kept)

    # all present: no cluster for two workers, nothing rewritten, nothing redrawn
    code = ('import sys\nfrom screwgear_ros.cli.sweep import main\n'
            f'rc = main([{str(path)!r}, "--out", {str(out)!r}, "--workers", "2"])\n'
            'print(rc, "distributed" in sys.modules)\n')
    again = subprocess.run([sys.executable, '-P', '-c', code], capture_output=True, text=True,
                           timeout=300, check=False)
    assert again.stdout.splitlines()[-1] == '0 False', again.stdout + again.stderr
    assert '0 to run' in again.stdout and 'up to date' in again.stdout
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()} == kept

    # damaged run files: each named, its run run again, the same bytes back
    runs = sorted((out / 'runs').glob('*.json'))
    whole = [p.read_bytes() for p in runs]
    row = json.loads(whole[1])
    runs[0].write_text('{"index": 0, "key": "' + row['key'] + '"}')
    runs[1].write_text(json.dumps({**row, 'metrics': []}))
    runs[2].write_bytes(whole[2][:17])
    resumed = installed('sweep', path, '--out', out, '--workers', '1', '--no-plot')
    assert resumed.returncode == 0 and 'Traceback' not in resumed.stderr, resumed.stderr
    assert resumed.stderr.count('is damaged') == 3 and 'its run is run again' in resumed.stderr
    assert "has no 'status'" in resumed.stderr and 'metrics is not a list of 1' in \
        resumed.stderr
    assert '0 finished before, 3 to run' in resumed.stdout
    assert [json.loads(p.read_bytes())['metrics'] for p in runs] == \
        [json.loads(b)['metrics'] for b in whole]
