"""``identify`` on what a lab's recorder leaves (issue #46), against ground truth made
off the fitted model's tick grid (test/support/identify_retimed.py): the TRUTH table run
at 4 kHz with its commands at 1 kHz a quarter tick off the model's grid, then recorded
as a slower, jittered driver (a third of a period), with losses in bursts, repeated
messages, header stamps 2.5 ms off the log times and the lab's joint names.

- the shipped chirp at 800 Hz (the noise seed differs from the base file), and a closed-loop PD following steps with a dither at 500 Hz placed by the
  log times (pinion friction, Stribeck speed, drive lag and noise seed differ):
  stiffness, inertia and preload within 2 %, mesh damping and table friction within
  10 %, and on the chirp the verdict "explains";
- a viscous loss the data has and the base file leaves out: the verdict "does not", and
  no parameter called determined;
- a rate below the mesh mode, and too few samples after the losses: exit 2, one line
  naming the parameters.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from identify_retimed import LAB_NAMES, chirp, pd_steps, record_fine, retime
from identify_truth import TRUTH, write_base

import screwgear_ros
from screwgear_ros.cli.identify import main

FIVE = ('mesh_stiffness_mean', 'inertia_table', 'preload_torque', 'mesh_damping',
        'table_coulomb_torque')
TOLERANCE = {'mesh_stiffness_mean': 0.02, 'inertia_table': 0.02, 'preload_torque': 0.02,
             'mesh_damping': 0.10, 'table_coulomb_torque': 0.10}
#: What differs on the recorded table from the base file, not fitted: under the closed
#: loop (which holds the table where the recording has it) all four; the open-loop chirp,
#: whose verdict must be "explains" (the model's own structure), only the noise seed (its
#: replay drifts with any friction mismatch: a 3.6 % pinion friction took the stiffness
#: 14 % off, the case multiple shooting is for; and a drive lag 1 % off leaves the table
#: 5× its 26-bit encoder's noise, which the verdict rightly calls unexplained).
UNFITTED = {'pinion_coulomb_torque': 0.06, 'pinion_stribeck_speed': 0.45,
            'drive_time_constant': 1.85e-4, 'sensor_seed': 5}
OPEN_LOOP_UNFITTED = {'sensor_seed': 5}
DURATION = 3.0
#: The closed loop's recording (the suite's time budget; at 500 Hz less the losses it keeps
#: the 250 samples a fitted parameter needs).
PD_DURATION = 2.8


@pytest.fixture(scope='module')
def lab(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp('identify_lab')
    fine_chirp = record_fine(root / 'fine_chirp', chirp(DURATION), DURATION,
                             **OPEN_LOOP_UNFITTED)
    fine_pd = record_fine(root / 'fine_pd', pd_steps(PD_DURATION), PD_DURATION, **UNFITTED)
    return {'root': root,
            'chirp': retime(fine_chirp, root / 'lab_chirp', rate=800.0, seed=11),
            'pd': retime(fine_pd, root / 'lab_pd', rate=500.0, seed=12, storage='mcap'),
            'fine_chirp': fine_chirp}


def _recovered(result) -> None:
    for e in result.estimates:
        error = abs(e.value / TRUTH[e.name] - 1)
        assert error < TOLERANCE[e.name], (e.name, e.value, TRUTH[e.name])
        assert abs(e.base / TRUTH[e.name] - 1) > 0.02 or e.name == 'preload_torque', \
            'the fit started at the truth'


@pytest.mark.parametrize('kind, clock', [('chirp', 'stamp'), ('pd', 'log')])
def test_a_lab_recording_gives_the_table_back(lab, kind, clock):
    base = write_base(lab['root'] / f'base_{kind}.yaml', FIVE)
    result = screwgear_ros.identify([lab[kind]], base, list(FIVE), joints=LAB_NAMES,
                                    clock=clock, starts_count=1,
                                    output=lab['root'] / f'fitted_{kind}.yaml')
    assert result.finished
    _recovered(result)
    assert result.analysis is not None
    if kind == 'chirp':      # the model's own structure, values all but equal
        assert result.analysis.explains, result.analysis.verdict()
    else:                    # the unfitted friction differs: a verdict, honestly kept
        assert result.analysis.explains or all(e.undetermined for e in result.estimates)
    notes = '\n'.join(result.notes)
    for found in ('samples lost', 'repeated samples', 'jitter',
                  'preload_torque: started from'):
        assert found in notes, (found, notes)
    assert ('header stamps run +2.5 ms' in notes) == (clock == 'stamp'), notes
    report = result.report.read_text(encoding='utf-8')
    assert '## Residual analysis' in report
    assert ('explains the data' in report) == result.analysis.explains


def test_a_term_the_model_lacks_is_named_and_nothing_is_determined(lab, tmp_path):
    viscous = record_fine(tmp_path / 'fine_viscous', chirp(1.5), 1.5, table_damping=60.0)
    bag = retime(viscous, tmp_path / 'viscous', rate=1000.0, seed=13)
    base = write_base(tmp_path / 'base.yaml', ['inertia_table', 'table_coulomb_torque'])
    result = screwgear_ros.identify([bag], base, ['inertia_table', 'table_coulomb_torque'],
                                    joints=LAB_NAMES, starts_count=1, max_evaluations=8)
    assert not result.analysis.explains
    assert 'does NOT explain' in result.analysis.verdict()
    assert all(e.undetermined for e in result.estimates), result.estimates


def test_bad_lab_recordings_exit_2_with_one_line(lab, tmp_path, capsys):
    slow = retime(lab['fine_chirp'], tmp_path / 'slow', rate=200.0, seed=14)
    sparse = retime(lab['fine_chirp'], tmp_path / 'sparse', rate=250.0, loss=0.9, burst=40,
                    seed=15)
    cases = [([slow, '--fit', 'mesh_stiffness_mean,inertia_table'],
              'cannot determine mesh_stiffness_mean'),
             ([sparse, '--fit', 'inertia_table,table_coulomb_torque,preload_torque'],
              'too short to fit 3')]
    base = write_base(tmp_path / 'base.yaml', FIVE)
    for args, message in cases:
        code = main([str(a) for a in args] + ['--params', str(base), '--joints',
                    ','.join(f'{k}={v}' for k, v in LAB_NAMES.items()), '--no-progress',
                    '-o', str(tmp_path / 'fitted.yaml')])
        err = capsys.readouterr().err
        assert code == 2, (args, err)
        assert err.startswith('identify: ') and message in err and err.count('\n') == 1, err
    assert not (tmp_path / 'fitted.yaml').exists()
