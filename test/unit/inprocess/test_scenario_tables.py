"""A scenario's table (``parameters_file``, ``run_scenario --params``), its settling band
and user metrics, and controllers that fail: named, with the rule, never a raw internal
error (issue #45 items 9 and 10, issue #43)."""

from __future__ import annotations

import math
import random
import textwrap
from pathlib import Path

import numpy as np
import pytest
from paths import ROOT

from screwgear_ros.cli.run_scenario import main
from screwgear_ros.inprocess.metrics import METRIC_DOCS, SettlingBand, run_metrics
from screwgear_ros.inprocess.scenario import ScenarioError, load_scenario

REALISTIC = ROOT / 'config' / 'realistic.yaml'


def _write(directory: Path, name: str, text: str) -> Path:
    path = directory / name
    path.write_text(textwrap.dedent(text), encoding='utf-8')
    return path


def test_a_scenario_runs_on_the_parameter_file_it_names_and_says_so(tmp_path, capsys):
    scenario = _write(tmp_path, 's.yaml', f'''\
        parameters_file: {REALISTIC}
        parameters: {{table_coulomb_torque: 2.5}}
        duration: 0.01
        ''')
    loaded = load_scenario(scenario)
    values = dict(loaded.values)
    assert values['encoder_counts_table'] == 2 ** 26           # from the file
    assert values['table_coulomb_torque'] == 2.5                # the scenario's own on top
    assert loaded.parameters_file == str(REALISTIC)
    assert main([str(scenario)]) == 0
    assert f'parameters: {REALISTIC}' in capsys.readouterr().out


def test_params_replaces_the_scenarios_file_and_the_default_is_named(tmp_path, capsys):
    scenario = _write(tmp_path, 's.yaml', 'duration: 0.01\n')
    assert load_scenario(scenario).parameters_file is None
    assert main([str(scenario)]) == 0
    assert "the node's defaults (the paper's ideal table" in capsys.readouterr().out
    assert dict(load_scenario(scenario, REALISTIC).values)['table_static_torque'] == 4.0
    assert main([str(scenario), '--params', str(REALISTIC)]) == 0


@pytest.mark.parametrize('text, words', [
    ('parameters_file: no_such.yaml\nduration: 0.01\n', ['line 1', 'no_such.yaml']),
    ('parameters_file: [1]\nduration: 0.01\n', ['line 1', 'parameters_file']),
    ('duration: 0.01\nsettling_band: {percent: 2}\n', ['line 2', 'fraction']),
    ('duration: 0.01\nsettling_band: {rad: -1}\n', ['line 2', 'must be > 0']),
    ('duration: 0.01\nsettling_band: {counts: 2}\n', ['line 2', 'encoder_counts_table is 0']),
    ('duration: 0.01\nmetrics: {max_abs_te_m: m:f}\n', ['line 2', 'built-in']),
    ('duration: 0.01\nmetrics: {mine: nomodule_here:f}\n', ['line 2', 'cannot be loaded']),
])
def test_bad_tables_bands_and_metrics_name_their_line(tmp_path, text, words):
    with pytest.raises(ScenarioError) as caught:
        load_scenario(_write(tmp_path, 's.yaml', text))
    assert all(w in str(caught.value) for w in words), str(caught.value)


def test_a_band_in_counts_is_that_many_counts_of_the_joints_encoder():
    """A step response ``angle = after − size·exp(−t/T)`` settles into ±b rad at
    T·ln(|size|/b) (closed form), whatever the step's size; the relative band ±2 % at
    T·ln(50)."""
    t = np.arange(0.0, 1.0, 1e-3)
    size, tau, counts = 1e-3, 0.05, 2 ** 20
    angle = size * (1.0 - np.exp(-t / tau))

    class FakeRun:
        time = t
        true_position = np.column_stack([angle, angle, angle])
        mesh_force = np.zeros((len(t), 2))
        transmission_error = np.zeros(len(t))
        direction = np.ones(len(t), dtype=np.int8)
        fault = None

        class settings:
            joint_names = ('p1', 'table', 'p3')
            steps_per_publish, dt = 1, 1e-3
            encoder_counts_table = counts

        def __len__(self):
            return len(t)

    band = SettlingBand(5, 'counts')
    width = 5 * 2 * math.pi / counts
    m = run_metrics(FakeRun(), setpoint=lambda _: size, band=band)
    assert m.steps[0].settling_time == pytest.approx(tau * math.log(size / width), abs=1.5e-3)
    relative = run_metrics(FakeRun(), setpoint=lambda _: size)
    assert relative.steps[0].settling_time == pytest.approx(tau * math.log(50.0), abs=1.5e-3)
    with pytest.raises(ValueError, match='encoder'):
        SettlingBand(2, 'counts').width(1.0, 0)


def test_a_user_metric_is_a_column_and_a_failing_one_is_named(tmp_path, capsys):
    _write(tmp_path, 'my_metrics.py', '''\
        def final(run, setpoint):
            return float(run.true_position[-1, 1] - setpoint(0.0))
        def text(run, setpoint):
            return 'good'
        ''')
    scenario = _write(tmp_path, 's.yaml', '''\
        duration: 0.02
        controller: {use: demo}
        setpoint: {profile: steps, points: [[0.0, 0.001]]}
        settling_band: {rad: 1.0e-5}
        metrics: {final: my_metrics:final}
        ''')
    loaded = load_scenario(scenario)
    run = loaded.run()
    values = loaded.metrics(run).as_dict()
    assert values['final'] == pytest.approx(run.true_position[-1, 1] - 0.001, abs=1e-15)
    assert main([str(scenario)]) == 0
    out = capsys.readouterr().out
    assert 'band ±1e-05 rad' in out and 'final' in out
    bad = _write(tmp_path, 'bad.yaml', scenario.read_text().replace('my_metrics:final',
                                                                     'my_metrics:text'))
    assert main([str(bad)]) == 2
    err = capsys.readouterr().err
    assert "metric final (my_metrics:text) returned 'good' (str)" in err


def test_every_metric_is_documented():
    text = (ROOT / 'docs' / 'scenarios.md').read_text(encoding='utf-8')
    assert all(f'`{name}`' in text for name in METRIC_DOCS)
    from screwgear_ros.sweep.spec import METRICS
    assert set(METRICS) == set(METRIC_DOCS)


#: What a hostile controller may answer (source text; seeded below).
ANSWERS = ("'text'", '[1.0]', "{'effort': 1.0}", "b'1'", 'True', 'object()', '1j', '(0.5,)',
           "float('nan')", '10.0 ** 400 if False else float("inf")', 'None or "0"')
FAILURES = ('ZeroDivisionError', 'IndexError', 'KeyError', 'TypeError', 'OverflowError',
            'RuntimeError', 'AttributeError', 'ValueError')


@pytest.mark.parametrize('seed', range(6))
def test_controllers_that_fail_or_answer_junk_are_named_with_the_rule(tmp_path, capsys,
                                                                      seed):
    """Seeded fuzz family: a controller that raises one of several exceptions at a
    random tick, or answers junk of a random kind; run_scenario exits 2 with a message
    naming the controller, the tick and the rule or the user's own line, never a
    traceback."""
    r = random.Random(seed)
    raises, tick = r.random() < 0.5, r.randrange(0, 5)
    kind, answer = r.choice(FAILURES), r.choice(ANSWERS)
    module = f'ctl_fuzz_{seed}'
    _write(tmp_path, f'{module}.py', f'''\
        def make(setpoint):
            count = [0]
            def controller(observation):
                count[0] += 1
                if count[0] > {tick}:
                    if {raises}:
                        raise {kind}('inner detail')
                    return {answer}
                return 0.0
            return controller
        ''')
    scenario = _write(tmp_path, 's.yaml', f'''\
        duration: 0.01
        controller: {{use: {module}:make}}
        ''')
    assert main([str(scenario)]) == 2, f'seed {seed}'
    err = capsys.readouterr().err
    assert 'Traceback' not in err, f'seed {seed}: {err}'
    if raises:
        assert f'controller {module}:make (line 2) raised {kind}' in err, f'seed {seed}: {err}'
        assert f'{module}.py, line 7' in err, f'seed {seed}: {err}'
    else:
        assert (f'controller {module}:make (line 2) answered' in err and 'real number' in err
                or 'refuses' in err and 'finite' in err), f'seed {seed}: {err}'
