"""sweep: a small sweep gives the same metric bytes in this process, on a real Dask
LocalCluster of two worker processes and across an interrupted-then-resumed run; a bad
sweep file names its line and exits 2; a run that diverges, fails or overruns its time
limit is a row with its reason; a worst run's rerun file reproduces its row."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from bag_runs import installed
from paths import ROOT

from screwgear_ros.params.table import TableParams
from screwgear_ros.physics.quantities import natural_frequency

pq = pytest.importorskip('pyarrow.parquet')

SCENARIO = """\
parameters: {command_timeout: 0.0}
duration: 0.3
controller:
  use: demo
setpoint: {profile: steps, points: [[0.0, 0.01], [0.15, -0.01]]}
"""

SWEEP = """\
scenario: scenario.yaml
metrics: [max_lost_motion_rad, max_abs_te_m, rms_tracking_error_rad, peak_mesh_force_1_n]
time_limit: 60
grid:
  preload_torque: [150.0, 350.0]
monte_carlo:
  count: 5
  seed: 11
  parameters:
    backlash: {uniform: [0.0, 100.0e-6]}
    ste_amplitudes: {scale: {truncated_normal: [1.0, 0.3, 0.5, 1.5]}}
    temperature_rise: {normal: [20.0, 5.0]}
"""
RUNS = 10


def _sweep_dir(tmp_path: Path, sweep: str = SWEEP, scenario: str = SCENARIO,
               name: str = 'case') -> Path:
    directory = tmp_path / name
    directory.mkdir()
    (directory / 'scenario.yaml').write_text(scenario)
    (directory / 'sweep.yaml').write_text(sweep)
    return directory / 'sweep.yaml'


def _table(out: Path) -> dict[str, list]:
    return pq.read_table(out / 'results.parquet').to_pydict()


def _metric_bytes(out: Path, metrics: list[str]) -> dict[str, bytes]:
    table = pq.read_table(out / 'results.parquet')
    return {name: table.column(name).to_numpy().tobytes() for name in metrics}


METRICS = ['max_lost_motion_rad', 'max_abs_te_m', 'rms_tracking_error_rad',
           'peak_mesh_force_1_n']


@pytest.mark.ros
def test_one_worker_two_workers_and_a_resumed_run_give_the_same_bytes(tmp_path):
    path = _sweep_dir(tmp_path)
    one = installed('sweep', path, '--out', tmp_path / 'one', '--workers', '1')
    assert one.returncode == 0, one.stderr
    table = _table(tmp_path / 'one')
    assert table['index'] == list(range(RUNS)) and set(table['status']) == {'ok'}
    assert len(set(table['seed'])) == RUNS
    assert all(v > 0.0 for v in table['max_abs_te_m'])
    csv_text = (tmp_path / 'one' / 'results.csv').read_text().splitlines()
    assert len(csv_text) == RUNS + 1 and csv_text[0].startswith('index,seed,preload_torque')
    assert (tmp_path / 'one' / 'summary.png').stat().st_size > 10_000
    assert 'worst runs by max_lost_motion_rad' in one.stdout
    assert one.stdout.count('run_scenario ') == 5 and ' --record ' in one.stdout
    reference = _metric_bytes(tmp_path / 'one', METRICS)

    # a real LocalCluster: two worker processes, runs finishing in any order
    two = installed('sweep', path, '--out', tmp_path / 'two', '--workers', '2')
    assert two.returncode == 0, two.stderr
    assert 'LocalCluster of 2 worker processes' in two.stdout
    assert _metric_bytes(tmp_path / 'two', METRICS) == reference
    assert {k: v for k, v in _table(tmp_path / 'two').items() if k not in METRICS} == \
        {k: v for k, v in table.items() if k not in METRICS}

    # interrupted by a run-count limit, then on two workers, then finished in-process
    out = tmp_path / 'resumed'
    first = installed('sweep', path, '--out', out, '--workers', '1', '--max-runs', '3')
    assert first.returncode == 1 and 'resumes' in first.stderr
    assert len(list((out / 'runs').glob('*.json'))) == 3
    second = installed('sweep', path, '--out', out, '--workers', '2', '--max-runs', '3')
    assert second.returncode == 1 and '3 finished before' in second.stdout
    last = installed('sweep', path, '--out', out, '--workers', '1')
    assert last.returncode == 0 and f'6 finished before, {RUNS - 6} to run' in last.stdout
    assert _metric_bytes(out, METRICS) == reference
    again = installed('sweep', path, '--out', out, '--workers', '1')
    assert again.returncode == 0 and '0 to run' in again.stdout
    assert _metric_bytes(out, METRICS) == reference


@pytest.mark.ros
def test_ctrl_c_keeps_the_finished_runs_and_a_rerun_completes_them(tmp_path):
    sweep = SWEEP.replace('count: 5', 'count: 15')
    path = _sweep_dir(tmp_path, sweep)
    out = tmp_path / 'out'
    proc = subprocess.Popen([sys.executable, '-P', '-m', 'screwgear_ros.cli.sweep', str(path),
                             '--out', str(out), '--workers', '1', '--no-plot'],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline and len(list(out.glob('runs/*.json'))) < 3:
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1, stdout + stderr
    assert 'interrupted' in stderr and 'Traceback' not in stderr
    kept = sorted(out.glob('runs/*.json'))
    assert 3 <= len(kept) < 30
    rows = [json.loads(p.read_text()) for p in kept]       # every kept file is whole
    assert all(row['status'] == 'ok' for row in rows)
    assert len(_table(out)['index']) == len(kept)          # partial results written
    rest = installed('sweep', path, '--out', out, '--workers', '1', '--no-plot')
    assert rest.returncode == 0, rest.stderr
    assert f'{len(kept)} finished before' in rest.stdout
    fresh = installed('sweep', path, '--out', tmp_path / 'fresh', '--workers', '1',
                      '--no-plot')
    assert fresh.returncode == 0
    assert _metric_bytes(out, METRICS) == _metric_bytes(tmp_path / 'fresh', METRICS)


@pytest.mark.ros
def test_a_changed_sweep_in_an_old_directory_is_refused(tmp_path):
    path = _sweep_dir(tmp_path, SWEEP.replace('count: 5', 'count: 1'))
    out = tmp_path / 'out'
    assert installed('sweep', path, '--out', out, '--workers', '1', '--no-plot',
                     '--max-runs', '1').returncode == 1
    path.write_text(SWEEP.replace('count: 5', 'count: 2'))
    changed = installed('sweep', path, '--out', out, '--workers', '1')
    assert changed.returncode == 2 and 'Traceback' not in changed.stderr
    assert 'holds another sweep' in changed.stderr and 'count is 2, was 1' in changed.stderr
    assert len(list(out.glob('runs/*.json'))) == 1                     # nothing lost


BAD = {
    'unknown_parameter': ('grid:\n  backlash_gap: [0.0]\n', 'backlash_gap', 'not a parameter'),
    'refused_value': ('grid:\n  preload_torque: [100.0, -5.0]\n', 'preload_torque',
                      'refused by table_sim'),
    # redraw: 0: a draw the node refuses refuses the sweep (by default it is drawn again)
    'drawn_value_refused': (('monte_carlo:\n  count: 40\n  seed: 1\n  redraw: 0\n  parameters:\n'
                            '    backlash: {normal: [1.0e-5, 2.0e-5]}\n'), 'backlash',
                            'refused by table_sim'),
    'rk4_stability': ('grid:\n  mesh_stiffness_mean: [1.0e+7, 1.0e+12]\n',
                      'mesh_stiffness_mean', 'RK4 is unstable'),
    'node_only_setting': ('grid:\n  record: [a, b]\n', 'record', ('no meaning for an '
                          'in-process run')),
    'number_read_as_text': ('grid:\n  backlash: [0.0, 1e-5]\n', 'backlash',
                            'YAML reads 1e-5 as text'),
    'unknown_metric': ('grid:\n  backlash: [0.0]\n', 'max_wobble', 'unknown metric'),
    'bad_distribution': (('monte_carlo:\n  count: 3\n  parameters:\n'
                         '    backlash: {gaussian: [1.0, 2.0]}\n'), 'gaussian', 'uniform'),
    'uniform_backwards': (('monte_carlo:\n  count: 3\n  parameters:\n'
                          '    backlash: {uniform: [1.0e-4, 0.0]}\n'), 'uniform',
                          'low must be below high'),
}


@pytest.mark.ros
@pytest.mark.parametrize('case', sorted(BAD))
def test_a_bad_entry_names_its_line_and_exits_2(case, tmp_path):
    body, needle, reason = BAD[case]
    metrics = 'max_wobble' if case == 'unknown_metric' else 'max_abs_te_m'
    text = f'scenario: scenario.yaml\nmetrics: [{metrics}]\n{body}'
    path = _sweep_dir(tmp_path, text)
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '1')
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert 'Traceback' not in proc.stderr and proc.stderr.count('\n') == 1
    line = next(k + 1 for k, row in enumerate(text.splitlines()) if needle in row)
    assert f'line {line}:' in proc.stderr and reason in proc.stderr, proc.stderr
    assert not (tmp_path / 'out' / 'runs').exists()          # nothing ran


CONTROLLERS = """\
import time


def make(setpoint, behaviour):
    def controller(observation):
        if behaviour == 'raise' and observation.time > 0.05:
            raise ZeroDivisionError('the controller divides by zero')
        if behaviour == 'sleep':
            time.sleep(0.02)
        return 10.0
    return controller
"""


@pytest.mark.ros
def test_faulting_failing_and_overrunning_runs_are_rows(tmp_path):
    # a parametric resonance of the mesh stiffness (test_node_fault.py) diverges
    # at twice the natural frequency; without the pumping (k_a = 0) it stays at rest
    unstable = {'mode': 'conventional', 'backlash': 0.0, 'mesh_phase': 'time', 'mesh_damping': 0.0}
    omega_0 = natural_frequency(TableParams(**unstable))
    unstable['mesh_frequency'] = 2.0 * omega_0
    scenario = ('parameters: {' + ', '.join(f'{k}: {v!r}' for k, v in unstable.items())
                + '}\nduration: 2.5\n')
    sweep = ('scenario: scenario.yaml\nmetrics: [max_abs_te_m, faulted]\n'
             'grid:\n  mesh_stiffness_amplitude: [0.0, 9.0e+6]\n')
    path = _sweep_dir(tmp_path, sweep, scenario, 'diverging')
    proc = installed('sweep', path, '--out', tmp_path / 'diverging' / 'out', '--workers', '1')
    assert proc.returncode == 0, proc.stderr
    table = _table(tmp_path / 'diverging' / 'out')
    assert table['status'] == ['ok', 'fault'] and table['faulted'] == [0.0, 1.0]
    assert 'non-finite' in table['reason'][1]

    for behaviour, status, reason in (('raise', 'error', 'ZeroDivisionError'),
                                      ('sleep', 'timeout', 'time limit of 0.5 s')):
        scenario = (f'duration: 2.0\ncontroller:\n  use: controllers:make\n'
                    f'  parameters: {{behaviour: {behaviour}}}\n')
        sweep = ('scenario: scenario.yaml\nmetrics: [max_abs_te_m]\ntime_limit: 0.5\n'
                 'grid:\n  backlash: [1.0e-5, 2.0e-5]\n')
        path = _sweep_dir(tmp_path, sweep, scenario, behaviour)
        (path.parent / 'controllers.py').write_text(CONTROLLERS)
        started = time.monotonic()
        proc = installed('sweep', path, '--out', path.parent / 'out', '--workers', '1')
        assert proc.returncode == 0, proc.stderr
        table = _table(path.parent / 'out')
        assert table['status'] == [status, status], table
        assert all(reason in r for r in table['reason'])
        assert all(math.isnan(v) for v in table['max_abs_te_m'])     # NaN: no metrics
        if behaviour == 'sleep':     # 2 s of simulation at 20 ms a tick: stopped, not run
            assert time.monotonic() - started < 60.0


@pytest.mark.ros
def test_the_rerun_file_of_a_worst_run_reproduces_its_row(tmp_path):
    from screwgear_ros.inprocess.metrics import run_metrics
    from screwgear_ros.inprocess.scenario import load_scenario

    path = _sweep_dir(tmp_path, SWEEP.replace('count: 5', 'count: 2'))
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '1', '--no-plot')
    assert proc.returncode == 0
    table = _table(tmp_path / 'out')
    worst = max(range(len(table['index'])), key=lambda k: table['max_lost_motion_rad'][k])
    rerun = tmp_path / 'out' / 'reruns' / f'run_{table["index"][worst]:06d}.yaml'
    assert f'run_scenario {rerun} --record' in proc.stdout
    scenario = load_scenario(rerun)
    run = scenario.run()
    metrics = run_metrics(run, scenario.setpoint).as_dict()
    assert [metrics[name] for name in METRICS] == [table[name][worst] for name in METRICS]


@pytest.mark.ros
def test_one_worker_imports_no_dask_and_the_package_imports_without_it(tmp_path):
    path = _sweep_dir(tmp_path, SWEEP.replace('count: 5', 'count: 1'))
    code = ('import sys\nfrom screwgear_ros.cli.sweep import main\n'
            f'rc = main([{str(path)!r}, "--out", {str(tmp_path / "out")!r}, "--workers", "1",'
            ' "--no-plot"])\n'
            'print(rc, sorted(m for m in sys.modules if m.split(".")[0] in '
            '("dask", "distributed")))\n')
    proc = subprocess.run([sys.executable, '-P', '-c', code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert proc.stdout.splitlines()[-1] == '0 []', proc.stdout + proc.stderr
    code = ('import sys\nsys.modules["dask"] = sys.modules["distributed"] = '
            'sys.modules["pyarrow"] = None\nimport screwgear_ros, screwgear_ros.sweep, '
            'screwgear_ros.cli.sweep\nprint("imported")\n')
    proc = subprocess.run([sys.executable, '-P', '-c', code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert proc.stdout.strip() == 'imported', proc.stderr


def test_the_launcher_is_where_ros2_run_looks():
    launcher = Path(sys.prefix) / 'lib' / 'screwgear_ros' / 'sweep'
    assert launcher.is_file() and '/../../bin/sweep"' in launcher.read_text()


PD = """\
def make(setpoint, kp, kd):
    def controller(observation):
        angle, rate = observation.position[1], observation.velocity[1]
        return max(-300.0, min(300.0, kp * (setpoint(observation.time) - angle) - kd * rate))
    return controller
"""


@pytest.mark.ros
def test_a_cluster_from_dask_scheduler_and_dask_worker_runs_the_sweep(tmp_path):
    """--scheduler: a cluster started as the README says; the worker runs elsewhere (its
    own directory) and gets the scenario and the controller module as contents."""
    dask = Path(sys.executable).with_name('dask')
    scheduler_file = tmp_path / 'scheduler.json'
    scenario = ('parameters: {command_timeout: 0.0}\nduration: 0.3\ncontroller:\n'
                '  use: pd_law:make\n  parameters: {kp: 3000.0, kd: 200.0}\n'
                'setpoint: {profile: sine, amplitude: 0.01, frequency: 2.0}\n')
    sweep = ('scenario: scenario.yaml\nmetrics: [rms_tracking_error_rad, max_abs_te_m]\n'
             'grid:\n  backlash: [0.0, 5.0e-5]\n  preload_torque: [100.0, 300.0]\n')
    path = _sweep_dir(tmp_path, sweep, scenario)
    (path.parent / 'pd_law.py').write_text(PD)
    elsewhere = tmp_path / 'worker_home'
    elsewhere.mkdir()
    processes = []
    try:
        processes.append(subprocess.Popen(
            [str(dask), 'scheduler', '--host', '127.0.0.1', '--port', '0', '--no-dashboard',
             '--scheduler-file', str(scheduler_file)], cwd=elsewhere,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + 120.0
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())['address']
        processes.append(subprocess.Popen(
            [str(dask), 'worker', address, '--nworkers', '1', '--nthreads', '1',
             '--no-dashboard'], cwd=elsewhere,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        remote = installed('sweep', path, '--out', tmp_path / 'remote', '--scheduler',
                           address, '--no-plot')
    finally:
        for process in reversed(processes):
            process.terminate()
            process.wait(timeout=60)
    assert remote.returncode == 0, remote.stderr
    assert f'the Dask cluster at {address}' in remote.stdout
    local = installed('sweep', path, '--out', tmp_path / 'local', '--workers', '1',
                      '--no-plot')
    assert local.returncode == 0, local.stderr
    metrics = ['rms_tracking_error_rad', 'max_abs_te_m']
    assert set(_table(tmp_path / 'remote')['status']) == {'ok'}
    assert _metric_bytes(tmp_path / 'remote', metrics) == \
        _metric_bytes(tmp_path / 'local', metrics)


@pytest.mark.ros
def test_without_dask_or_pyarrow_the_sweep_says_what_to_install(tmp_path):
    path = _sweep_dir(tmp_path, SWEEP.replace('count: 5', 'count: 1'))
    code = ('import sys\nsys.modules["dask"] = sys.modules["distributed"] = '
            'sys.modules["pyarrow"] = None\nfrom screwgear_ros.cli.sweep import main\n'
            'print("rc", main(sys.argv[1:]))\n')
    common = [sys.executable, '-P', '-c', code, str(path), '--no-plot']
    many = subprocess.run([*common, '--out', str(tmp_path / 'many'), '--workers', '2'],
                          capture_output=True, text=True, timeout=300, check=False)
    assert many.stdout.splitlines()[-1] == 'rc 2' and 'Traceback' not in many.stderr
    assert "pip install 'screwgear_ros[sweep]'" in many.stderr and '--workers 1' in many.stderr
    one = subprocess.run([*common, '--out', str(tmp_path / 'one'), '--workers', '1'],
                         capture_output=True, text=True, timeout=300, check=False)
    assert one.stdout.splitlines()[-1] == 'rc 0', one.stderr
    assert 'results.parquet needs pyarrow' in one.stderr
    assert (tmp_path / 'one' / 'results.csv').is_file()
    assert not (tmp_path / 'one' / 'results.parquet').exists()


BLOCKING = """\
import time


def make(setpoint):
    def controller(observation):
        if observation.effort[0] > 100.0:      # the preloaded runs: blocked for good
            time.sleep(3600.0)
        return None
    return controller
"""


@pytest.mark.ros
def test_a_blocked_run_on_a_cluster_ends_its_worker_and_the_sweep_goes_on(tmp_path):
    """A controller that never returns (no deadline check can run): past the hard limit
    the worker process ends, the run is a row, the restarted worker takes the rest. A
    blocked run among the first (one run a task) and one among the last (by then the
    short runs go several to a task): the runs that shared its task are rows of their
    own, and a restarted worker loads the model before its first run's clock starts."""
    from screwgear_ros.sweep.worker import hard_limit

    scenario = 'parameters: {command_timeout: 0.0}\nduration: 0.1\ncontroller:\n' \
               '  use: blocking:make\n'
    preloads = [0.0] * 16
    preloads[1] = preloads[12] = 350.0
    sweep = ('scenario: scenario.yaml\nmetrics: [max_abs_te_m]\ntime_limit: 1.0\n'
             f'grid:\n  preload_torque: {preloads}\n')
    path = _sweep_dir(tmp_path, sweep, scenario)
    (path.parent / 'blocking.py').write_text(BLOCKING)
    started = time.monotonic()
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '2', '--no-plot',
                     timeout=600)
    assert proc.returncode == 0, proc.stderr
    table = _table(tmp_path / 'out')
    assert table['status'] == ['error' if p else 'ok' for p in preloads], table
    for k in (1, 12):
        assert f'hard limit of {hard_limit(1.0):g} s' in table['reason'][k]
    assert time.monotonic() - started < 400.0


def test_batches_hold_about_their_time_of_runs_and_spread_the_last(tmp_path):
    """Cluster tasks: one run each until a run's time is known, then about
    BATCH_SECONDS of runs (at most MAX_BATCH), never so many that the runs left would
    leave a worker thread without one; every run once, in order."""
    from screwgear_ros.sweep import load_sweep
    from screwgear_ros.sweep.engine import BATCH_SECONDS, MAX_BATCH, Batches
    from screwgear_ros.sweep.worker import Outcome, Status

    values = ', '.join(f'{k // 3}.0e-6' for k in range(300))
    sweep = load_sweep(_sweep_dir(tmp_path, 'scenario: scenario.yaml\nmetrics: '
                                  f'[max_abs_te_m]\ngrid:\n  backlash: [{values}]\n'))
    batches, taken = Batches(sweep.runs), []

    def ran(seconds: float) -> None:
        batches.record(Outcome(0, '', Status.OK, '', (), seconds))

    taken.append(batches.take(2))
    assert len(taken[-1]) == 1
    ran(math.nan)                       # a run lost with its worker: no time
    taken.append(batches.take(2))
    assert len(taken[-1]) == 1
    ran(BATCH_SECONDS / 4)
    taken.append(batches.take(2))
    assert len(taken[-1]) == 4
    ran(BATCH_SECONDS / 4)              # the mean of the times back so far
    ran(BATCH_SECONDS / 1000)
    taken.append(batches.take(2))
    assert len(taken[-1]) == int(3 / (0.5 + 0.001)) > 4
    for _ in range(200):
        ran(BATCH_SECONDS / 1000)
    taken.append(batches.take(2))
    assert len(taken[-1]) == MAX_BATCH
    while batches.left:
        left = len(batches.left)
        taken.append(batches.take(3))
        assert len(taken[-1]) == max(1, min(MAX_BATCH, left // 3))
    assert [spec.index for batch in taken for spec in batch] == \
        [spec.index for spec in sweep.runs]


@pytest.mark.ros
def test_the_worked_example_covers_its_tolerance_band_and_runs(tmp_path):
    from screwgear_ros.sweep import load_sweep

    path = ROOT / 'docs' / 'examples' / 'tolerance_sweep.yaml'
    sweep = load_sweep(path)
    assert len(sweep.runs) >= 200
    drawn = {column: [dict(r.swept)[column] for r in sweep.runs] for column in sweep.columns}
    for column, low, high in (('backlash', 0.0, 100e-6), ('preload_torque', 0.0, 400.0),
                              ('ste_amplitudes_scale', 0.5, 1.5),
                              ('temperature_rise', 0.0, 40.0)):
        values = drawn[column]
        assert low <= min(values) < low + 0.1 * (high - low)
        assert high - 0.1 * (high - low) < max(values) <= high
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '1',
                     '--max-runs', '2', '--no-plot')
    assert proc.returncode == 1 and set(_table(tmp_path / 'out')['status']) == {'ok'}


@pytest.mark.ros
def test_a_rerun_validates_only_the_runs_it_has_not_finished(tmp_path):
    """The finished runs' keys are exactly the sweep's; given them, the sweep resolves to
    the same runs; a run whose key is not among them is still validated and refused."""
    from screwgear_ros.sweep import SweepError, load_sweep
    from screwgear_ros.sweep.store import finished_keys

    path = _sweep_dir(tmp_path, SWEEP.replace('count: 5', 'count: 1'),
                      SCENARIO.replace('duration: 0.3', 'duration: 0.02'))
    proc = installed('sweep', path, '--out', tmp_path / 'out', '--workers', '1', '--no-plot')
    assert proc.returncode == 0, proc.stderr
    keys = finished_keys(tmp_path / 'out')
    sweep = load_sweep(path)
    assert keys == {r.key for r in sweep.runs} and len(keys) == 2
    assert load_sweep(path, validated=keys).runs == sweep.runs
    bad = _sweep_dir(tmp_path, SWEEP.replace('[150.0, 350.0]', '[150.0, 350.0, -1.0]')
                     .replace('count: 5', 'count: 1'), name='bad')
    with pytest.raises(SweepError, match='run 2 .*preload_torque'):
        load_sweep(bad, validated=keys)
    assert finished_keys(tmp_path / 'nothing here') == frozenset()

    # its report piped into a reader that leaves at once (``| head``): a quiet end
    cli = Path(sys.executable).with_name('sweep')
    rerun = subprocess.Popen([str(cli), str(path), '--out', str(tmp_path / 'out'),
                              '--no-plot'], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    rerun.stdout.close()
    said = rerun.stderr.read().decode()
    assert rerun.wait(timeout=60) == 141 and 'Traceback' not in said, said


@pytest.mark.ros
def test_the_load_now_counts_busy_processes_as_they_run():
    """Two processes that spin are two tasks on the run queue the moment they run, which
    the 1-minute load average would show only a minute later."""
    from screwgear_ros.sweep.engine import free_workers, load_now

    spinners = [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
                for _ in range(2)]
    try:
        time.sleep(1.0)                  # started and spinning
        assert load_now() >= 1.5
        assert free_workers(300, allowed=2).count == 1
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()
